// What `contego kmod load` says when contego.ko refuses CONTEGO_KMOD_LOAD:
// for a module and a contego of different interfaces, which side is out of
// date and which build to take; for the verifier, where it stopped.
#include "cli/kmod_load_error.h"

#include <cerrno>
#include <gtest/gtest.h>
#include <string>

namespace contego::cli {
namespace {

bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

contego_kmod_load sent() {
  contego_kmod_load r{};
  r.version = CONTEGO_KMOD_LOAD_VERSION;
  return r;
}

// A module from before the versioned request does not know its number.
TEST(KmodLoadError, EnottyNamesTheModuleAsOlder) {
  const std::string m = kmod_load_error(ENOTTY, sent());
  EXPECT_TRUE(has(m, "the module is older than this contego")) << m;
  EXPECT_TRUE(has(m, "load the contego.ko built with this contego")) << m;
  EXPECT_TRUE(has(m, "version " + std::to_string(CONTEGO_KMOD_LOAD_VERSION))) << m;
}

// EPROTO with the module's version written back: older or newer.
TEST(KmodLoadError, EprotoNamesTheSideThatIsOutOfDate) {
  contego_kmod_load older = sent();
  older.version = CONTEGO_KMOD_LOAD_VERSION - 1;
  const std::string a = kmod_load_error(EPROTO, older);
  EXPECT_TRUE(has(a, "the module is older than this contego")) << a;
  const std::string ours = std::to_string(CONTEGO_KMOD_LOAD_VERSION);
  EXPECT_TRUE(has(a, "it takes load request version " + std::to_string(older.version) +
                         ", this contego sends version " + ours))
      << a;
  EXPECT_TRUE(has(a, "load the contego.ko built with this contego")) << a;

  contego_kmod_load newer = sent();
  newer.version = CONTEGO_KMOD_LOAD_VERSION + 1;
  const std::string b = kmod_load_error(EPROTO, newer);
  EXPECT_TRUE(has(b, "this contego is older than the module")) << b;
  EXPECT_TRUE(has(b, "it takes load request version " + std::to_string(newer.version) +
                         ", this contego sends version " + ours))
      << b;
  EXPECT_TRUE(has(b, "use the contego built with the loaded contego.ko")) << b;
}

// EPROTO for another size: the version could not be sent back (the request
// was not read); the kernel log names the module's.
TEST(KmodLoadError, EprotoOfAnotherSizePointsAtTheKernelLog) {
  const std::string m = kmod_load_error(EPROTO, sent());
  EXPECT_TRUE(has(m, "another size")) << m;
  EXPECT_TRUE(has(m, std::to_string(sizeof(contego_kmod_load)) + " bytes")) << m;
  EXPECT_TRUE(has(m, "the kernel log")) << m;
}

TEST(KmodLoadError, VerifierAndOtherErrors) {
  contego_kmod_load refused = sent();
  refused.status = 4;
  refused.section = 2;
  refused.index = 7;
  const std::string v = kmod_load_error(EINVAL, refused);
  EXPECT_TRUE(has(v, "verifier refused the image: status 4 (section 2, index 7)")) << v;
  EXPECT_TRUE(has(v, "the policy in force stays")) << v;
  const std::string e = kmod_load_error(EPERM, sent());
  EXPECT_TRUE(has(e, "load failed: Operation not permitted")) << e;
}

}  // namespace
}  // namespace contego::cli
