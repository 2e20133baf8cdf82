// The journal catalog installed with the package explains exactly the
// MESSAGE_IDs the monitor sends (cli/journal_sink.h): an id changed in one
// place and not the other would leave `journalctl -x` silent.
#include <fstream>
#include <gtest/gtest.h>
#include <set>
#include <string>

#include "cli/journal_sink.h"

namespace contego::cli {
namespace {

TEST(JournalCatalog, ExplainsEveryKindsMessageIdAndNoOther) {
  std::ifstream in(CONTEGO_CATALOG);
  ASSERT_TRUE(in) << CONTEGO_CATALOG;
  std::set<std::string> catalog;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("-- ", 0) == 0) catalog.insert(line.substr(3));
  }
  std::set<std::string> sent;
  for (const char* kind :
       {"decision", "latch", "audit-failure", "start", "start-refused", "safe-state", "fault",
        "reset", "stop", "reload", "reload-refused", "checkpoint"}) {
    const std::string id(journal_message_id(kind));
    EXPECT_EQ(id.size(), 32u) << kind;
    EXPECT_TRUE(catalog.contains(id)) << kind << " (" << id << ") is not in the catalog";
    sent.insert(id);
  }
  EXPECT_EQ(sent.size(), 12u) << "two kinds share an id";
  for (const std::string& id : catalog) EXPECT_TRUE(sent.contains(id)) << id << " is sent by none";
  EXPECT_FALSE(sent.contains(std::string(journal_message_id("shadow"))));
}

}  // namespace
}  // namespace contego::cli
