#include "cli/journal_sink.h"

#include <array>
#include <fmt/core.h>
#include <sys/uio.h>
#include <utility>
#include <vector>

#ifdef CONTEGO_HAVE_SYSTEMD
#include <systemd/sd-journal.h>
#endif

namespace contego::cli {

std::string_view journal_message_id(std::string_view kind) {
  // Made once (random), never changed: the catalog and users' queries name them.
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 12> kIds{{
      {"decision", "334d55ae757948bf9f52f566d57d4744"},
      {"latch", "c27b77bf0db14c9087e89c4f03878cde"},
      {"audit-failure", "969724f62f4545f98ce89cf5a10817ca"},
      {"start", "4f3828c1c2144a6180604c4cd6694372"},
      {"start-refused", "5809c603299346eb9a361d9f1fa85486"},
      {"safe-state", "8df9aae5ee33476fb535bdd380806357"},
      {"fault", "617d178447c940c6965248b72a15b634"},
      {"reset", "bf1c6509990c4cb2891a74fe63c41f86"},
      {"stop", "2e880b3021aa47e8825fed4e34147f3d"},
      {"reload", "fb6c3a66e1f8439c97153c1461357e0b"},
      {"reload-refused", "d89ee09a2dde4d55b0ffd79b502e780e"},
      {"checkpoint", "41e0c6f03c064eab929ee55a9f38db73"},
  }};
  for (const auto& [name, id] : kIds) {
    if (name == kind) return id;
  }
  return "bf405631b2bc46c786c0a9c51cd4ac3d";  // any other event
}

monitor::JournalSink make_journal_sink(std::string image_sha256) {
  return [image = std::move(image_sha256)](const monitor::JournalEntry& e) {
#ifdef CONTEGO_HAVE_SYSTEMD
    std::vector<std::string> fields{
        "MESSAGE=" + e.message,
        fmt::format("PRIORITY={}", static_cast<int>(e.priority)),
        fmt::format("MESSAGE_ID={}", journal_message_id(e.kind)),
        fmt::format("CONTEGO_KIND={}", e.kind),
    };
    if (!image.empty()) fields.push_back("CONTEGO_IMAGE_SHA256=" + image);
    for (const auto& [name, value] :
         {std::pair{"CONTEGO_TASK=", &e.task}, std::pair{"CONTEGO_DEVICE=", &e.device},
          std::pair{"CONTEGO_COMMAND=", &e.command}, std::pair{"CONTEGO_RULE=", &e.rule},
          std::pair{"CONTEGO_VERDICT=", &e.verdict}, std::pair{"CONTEGO_REASON=", &e.reason}}) {
      if (!value->empty()) fields.push_back(name + *value);
    }
    std::vector<iovec> iov;
    for (std::string& f : fields) iov.push_back({f.data(), f.size()});
    if (sd_journal_sendv(iov.data(), static_cast<int>(iov.size())) >= 0) return;
#endif
    fmt::print(stderr, "{}\n", e.message);
  };
}

}  // namespace contego::cli
