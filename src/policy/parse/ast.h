// The syntax tree of a policy file: what the user wrote, with source spans,
// before any name is resolved. Produced by parse(), consumed by check().
#ifndef CONTEGO_POLICY_PARSE_AST_H_
#define CONTEGO_POLICY_PARSE_AST_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "policy/source/source.h"

namespace contego::policy::ast {

struct Expr;
using ExprPtr = std::unique_ptr<Expr>;

enum class ExprKind : uint8_t {
  kInt,       // value
  kDuration,  // value (microseconds)
  kName,      // name
  kMember,    // kids[0].name  (device.value, signal list element group)
  kIndex,     // kids[0][kids[1]]
  kCall,      // name(kids...), arg_names[i] = "" for positional arguments
  kUnary,     // op kids[0]      op: "-", "not"
  kBinary,    // kids[0] op kids[1]   op: + - * / % == != < <= > >= and or
  kIn,        // kids[0] in kids[1]  (negated: not in); kids[1] is a kRange or kSet
  kRange,     // kids[0]..kids[1]
  kSet,       // {kids...}
  kList,      // [kids...]
  kError,     // placeholder after a syntax error
};

struct Expr {
  ExprKind kind = ExprKind::kError;
  Span span;
  int64_t value = 0;
  std::string name;  // identifier, member name, function name or operator
  Span name_span;
  bool negated = false;
  std::vector<ExprPtr> kids;
  uint32_t height = 1;  // of the tree below and including this node
  std::vector<std::string> arg_names;
  std::vector<Span> arg_name_spans;
};

struct Ident {
  std::string name;
  Span span;
};

// `dev`, `dev.cmd`, `dev.{a, b}`, `dev.led(5)`.
struct Selector {
  Ident device;
  std::vector<Ident> commands;  // empty: every command the rule's form implies
  ExprPtr index;                // register-map channel filter, may be null
  Span span;
};

enum class ResponseKind : uint8_t {
  kNone,
  kIgnore,
  kReject,
  kFailsafeCommand,
  kFailsafeExpected,
  kFailsafeAssign
};

struct Assign {
  Ident field;
  ExprPtr value;
};

struct Response {
  ResponseKind kind = ResponseKind::kNone;
  Span span;
  Ident errno_name;             // kReject (empty: EPERM)
  ExprPtr command;              // kFailsafeCommand: a kCall
  std::vector<Assign> assigns;  // kFailsafeAssign
};

struct ConstDecl {
  Ident name;
  ExprPtr value;
};

struct RegisterDecl {   // generic register maps: `register 0x02..0x03 flow : u16le range 0..4000`
  ExprPtr first, last;  // last may be null
  Ident name;
  Ident type;
  ExprPtr range;       // may be null
  bool query = false;  // `query register`: reading it needs read access only
  Span span;
};

struct ValueDecl {  // generic sensors: `value level at 0 : u16be range 0..1000`
  Ident name;
  ExprPtr offset;
  Ident type;
  ExprPtr range;
  Span span;
};

struct DeviceDecl {
  Ident name;
  Ident profile;
  ExprPtr bus;  // kInt after `i2c-`
  Span bus_span;
  ExprPtr address;
  ExprPtr sample_period;      // `sample 10ms`
  ExprPtr max_age;            // `max_age 50ms`
  std::vector<ExprPtr> safe;  // `safe stop(), led(5, off=0)`: kCall each
  Span safe_span;
  ExprPtr latch_count, latch_window;  // `latch after 3 violations within 1s`
  bool latch_unrepaired = false;      // `latch after 3 unrepaired violations within 1s`
  Span latch_span;
  // generic register maps
  bool auto_increment = false;
  std::vector<RegisterDecl> registers;
  std::vector<std::pair<ExprPtr, ExprPtr>> forbid;  // inclusive register ranges
  std::vector<Span> forbid_spans;
  ExprPtr sample_request;  // `read [0x00] length 4` : kList
  ExprPtr sample_length;
  Span read_span;
  std::vector<ValueDecl> values;
  Span span;
  bool incomplete = false;  // an item had a syntax error (already reported)
};

struct SignalDecl {
  Ident name;
  ExprPtr value;
};

struct TaskProperty {
  Ident key;
  ExprPtr value;     // null for `exe`, `user`, `group`, `unit`, `cgroup`, `ignore_errno`
  std::string text;  // their text (a numeric user or group id as digits)
};

struct TaskDecl {
  Ident name;
  std::vector<TaskProperty> properties;
  Span span;
  bool incomplete = false;  // an item had a syntax error (already reported)
};

struct OverheadDecl {
  ExprPtr value;
  Span span;
};

struct AllowDecl {
  Ident task;
  bool reads = false;  // `allow t reads d` (read access) vs `allow t -> d` (actuation)
  std::vector<Ident> devices;
  Span span;
};

struct LimitDecl {
  Ident task;
  Selector target;
  ExprPtr count;
  Response response;
  Span span;
};

enum class InvariantForm : uint8_t { kExpect, kRequire, kSequence };

struct InvariantDecl {
  Ident name;
  Selector target;
  InvariantForm form = InvariantForm::kRequire;
  ExprPtr when;                 // may be null (kRequire, kSequence)
  ExprPtr require;              // kRequire
  std::vector<ExprPtr> expect;  // kExpect: kCall each
  Ident sequence_field;         // kSequence
  ExprPtr sequence_values;      // kSequence: kList
  Ident scope;                  // kSequence: `scope session|task|device` (empty: the default)
  Response response;
  Span span;
  Span head_span;  // `invariant NAME`
};

struct File {
  std::vector<ConstDecl> consts;
  std::vector<DeviceDecl> devices;
  std::vector<SignalDecl> signals;
  std::vector<TaskDecl> tasks;
  std::vector<OverheadDecl> overheads;
  std::vector<AllowDecl> allows;
  std::vector<LimitDecl> limits;
  std::vector<InvariantDecl> invariants;
};

}  // namespace contego::policy::ast

#endif  // CONTEGO_POLICY_PARSE_AST_H_
