// verify_audit: the audit log's chain checked line by line (docs/audit-format.md).
#include <fcntl.h>
#include <setjmp.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include <mutex>
#include <nlohmann/json.hpp>  // the verifier only
#include <sstream>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/sysmacros.h>

#include "contego/core/checker.h"

#include "base/json_text.h"
#include "monitor/audit_internal.h"
#include "monitor/audit_log.h"
#include "monitor/sha256.h"

namespace contego::monitor {
namespace {

std::string fmt_line(uint64_t n, const std::string& why) {
  return "line " + std::to_string(n) + ": " + why;
}

// A record cut off by a kill is the start of a record: it opens an object,
// and if it got as far as its "prev", that names the hash of the line before
// (`prev_hash`; empty: any, for the first line of a file).
bool is_torn_record(std::string_view tail, std::string_view prev_hash) {
  if (tail != "{" && !tail.starts_with("{\"")) return false;
  static constexpr std::string_view kPrev = "\"prev\":\"";
  const size_t at = tail.find(kPrev);
  if (at == std::string_view::npos) return true;
  const std::string_view hash = tail.substr(at + kPrev.size(), 64);
  if (prev_hash.empty()) {
    return hash.find_first_not_of("0123456789abcdef") == std::string_view::npos;
  }
  return prev_hash.starts_with(hash);
}

}  // namespace

AuditCheck verify_audit(std::istream& in, const std::string& continues_from) {
  AuditCheck c;
  AuditSummary& s = c.summary;
  std::string line, prev_hash;
  auto fail = [&](const std::string& why) {
    c.ok = false;
    c.bad_line = s.lines + 1;
    c.error = fmt_line(c.bad_line, why);
    return c;
  };
  while (std::getline(in, line)) {
    // The writer never writes an empty line: one here was inserted.
    if (line.empty() && !in.eof()) return fail("blank line (inserted: the monitor writes none)");
    if (line.empty()) break;
    // getline stopped at the end of the file, not at a newline: the tail of
    // a mapped log whose monitor was killed. Zero padding is skipped; a
    // record cut off by the kill (its decision never acted: a record is
    // complete before its decision acts) is reported, not refused.
    const bool unterminated = in.eof();
    if (unterminated) {
      const size_t last = line.find_last_not_of('\0');
      if (last == std::string::npos) break;  // only padding
      line.resize(last + 1);
    }
    if (line.find('\0') != std::string::npos) return fail("zero bytes inside the log");
    if (unterminated &&
        (line.back() != '}' || nlohmann::json::parse(line, nullptr, false).is_discarded())) {
      if (!is_torn_record(line, s.lines == 0 ? std::string_view{} : prev_hash)) {
        return fail("text after the last record that is no record cut off by a kill");
      }
      s.torn_tail = true;
      break;
    }
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return fail("not a JSON object");
    if (!j.contains("prev") || !j["prev"].is_string()) return fail("no \"prev\" hash");
    const std::string prev = j["prev"].get<std::string>();
    if (s.lines == 0) {
      s.starts_at_genesis = prev == kAuditGenesis;
      s.first_prev = prev;
      if (j.value("kind", std::string()) == "continues" && j.contains("follows") &&
          j["follows"].is_string()) {
        s.follows = j["follows"].get<std::string>();
      }
      if (!continues_from.empty() && prev != continues_from) {
        return fail("the first line does not continue the file before: its \"prev\" is " + prev +
                    ", that file ends with " + continues_from +
                    " (files missing or out of order? give them oldest first)");
      }
    } else if (prev != prev_hash) {
      return fail(
          "\"prev\" is not the SHA-256 of the line before: that line was changed, or "
          "lines were removed or inserted here");
    }
    prev_hash = sha256_hex(line);
    ++s.lines;
    s.last_hash = prev_hash;
    if (j.contains("t_us") && j["t_us"].is_number_unsigned()) {
      const uint64_t t = j["t_us"].get<uint64_t>();
      if (s.first_us == 0) s.first_us = t;
      s.last_us = t;
    }
    const std::string kind = j.value("kind", std::string("?"));
    if (kind == "decision") {
      ++s.decisions;
      std::string decision = j.value("decision", std::string("?"));
      // Complain mode: the policy's verdict, but the command acted as sent.
      if (decision != "allow" && j.value("complain", false)) decision += " (complain: sent)";
      ++s.by_decision[decision];
      std::string task = j.contains("task_name") && j["task_name"].is_string()
                             ? j["task_name"].get<std::string>()
                             : (j.contains("task") ? json_text(j["task"]) : std::string("?"));
      ++s.by_task[task];
    } else {
      ++s.events[kind];
    }
  }
  return c;
}

}  // namespace contego::monitor
