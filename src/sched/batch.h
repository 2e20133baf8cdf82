// `contego sched --batch`: a stream of task sets in, one JSON result line per
// set out, at library speed (one process for any number of sets).
//
// Input: JSON lines (a line whose first non-blank character is '{' holds one
// set, the schema of parse_json) and/or CSV blocks (a header line, then rows,
// ended by a blank line, a JSON line or the end; the schema of parse_csv).
// Lines starting with '#' outside a block and blank lines are skipped.
//
// Output, per set, in input order: {"line": N, "schedulable": ..., "tasks":
// [...]} (docs/sched.md), or {"line": N, "error": "..."} for a set that does
// not parse or validate; the stream goes on after an error.
//
// Host code.
#ifndef CONTEGO_SCHED_BATCH_H_
#define CONTEGO_SCHED_BATCH_H_

#include <cstddef>
#include <iosfwd>
#include <optional>
#include <string>

#include "sched/assign.h"
#include "sched/duration.h"

namespace contego::sched {

struct BatchOptions {
  std::optional<Nanos> overhead;     // replaces every task's C^o (--overhead, --overhead-from)
  std::optional<Assignment> assign;  // unset: the set's own priorities (an error without them)
  bool sensitivity = true;
};

struct BatchSummary {
  size_t sets = 0;           // result lines written
  size_t failed = 0;         // of which errors
  size_t unschedulable = 0;  // of which sets some task of which can miss
  // Bytes handed to the set parsers: each line of the stream at most once,
  // so a stream costs time linear in its length (a block padded or
  // re-read from the start of the stream shows here, without timing).
  size_t parsed_bytes = 0;
};

// `source` names the stream in error messages ("source:LINE: ...", also
// written to `errors` when it is not null).
BatchSummary run_batch(std::istream& in, const std::string& source, const BatchOptions& options,
                       std::ostream& out, std::ostream* errors);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_BATCH_H_
