// The dumper of policy images (`contego image dump`): every record and the
// bytecode as text. A file of its own, so that the daemon, which reads
// images but never prints them, does not link it.
#include <fmt/format.h>

#include "contego/core/checker.h"

#include "image/image_model.h"

namespace contego::image {

namespace {

const char* op_name(core::Op op) {
  using core::Op;
  switch (op) {
    case Op::kNop:
      return "nop";
    case Op::kPush:
      return "push";
    case Op::kPushConst:
      return "pushc";
    case Op::kSignal:
      return "signal";
    case Op::kField:
      return "field";
    case Op::kCommand:
      return "command";
    case Op::kIndex:
      return "index";
    case Op::kJobCount:
      return "jobcount";
    case Op::kLastField:
      return "lastfield";
    case Op::kSinceLast:
      return "sincelast";
    case Op::kHasLast:
      return "haslast";
    case Op::kState:
      return "state";
    case Op::kSetState:
      return "setstate";
    case Op::kAdd:
      return "add";
    case Op::kSub:
      return "sub";
    case Op::kMul:
      return "mul";
    case Op::kDiv:
      return "div";
    case Op::kMod:
      return "mod";
    case Op::kNeg:
      return "neg";
    case Op::kAbs:
      return "abs";
    case Op::kMin:
      return "min";
    case Op::kMax:
      return "max";
    case Op::kEq:
      return "eq";
    case Op::kNe:
      return "ne";
    case Op::kLt:
      return "lt";
    case Op::kLe:
      return "le";
    case Op::kGt:
      return "gt";
    case Op::kGe:
      return "ge";
    case Op::kAnd:
      return "and";
    case Op::kOr:
      return "or";
    case Op::kNot:
      return "not";
    case Op::kDup:
      return "dup";
    case Op::kDrop:
      return "drop";
    case Op::kJumpIfZero:
      return "jz";
    case Op::kJump:
      return "jmp";
    case Op::kSubstBegin:
      return "subst";
    case Op::kSubstField:
      return "substfield";
    case Op::kPass:
      return "pass";
    case Op::kFail:
      return "fail";
    case Op::kFailSubst:
      return "failsubst";
    case Op::kReturn:
      return "ret";
  }
  return nullptr;
}

// A rule's response (ignore, failsafe, reject: a core::Decision), by the core's name.
const char* response_name(core::Response response) {
  const auto r = static_cast<uint8_t>(response);
  if (r == 0 || r > static_cast<uint8_t>(core::Decision::kReject)) return "?";
  return core::decision_name(static_cast<core::Decision>(r));
}

std::string mask_list(const core::CommandMask& m) {
  std::string out;
  for (uint32_t c = 0; c < 128; ++c) {
    if ((m.bits[c / 32] >> (c % 32)) & 1u) out += fmt::format("{}{}", out.empty() ? "" : ",", c);
  }
  return out.empty() ? "-" : out;
}

void disassemble(std::string& out, const ImageModel& m, uint32_t first, uint32_t len) {
  for (uint32_t pc = 0; pc < len; ++pc) {
    const uint32_t at = first + pc;
    if (at >= m.code.size()) {
      out += fmt::format("      {:4}  <outside CODE>\n", at);
      return;
    }
    const core::Insn& in = m.code[at];
    const char* name = op_name(in.op);
    std::string text = name ? name : fmt::format("op{}", static_cast<unsigned>(in.op));
    using core::Op;
    switch (in.op) {
      case Op::kPush:
        text += fmt::format(" {}", in.imm);
        break;
      case Op::kPushConst:
        text += fmt::format(" c{}", in.b);
        if (in.b < m.constants.size()) text += fmt::format("  ; = {}", m.constants[in.b]);
        break;
      case Op::kSignal:
        text += fmt::format(" s{}", in.b);
        if (in.b < m.signals.size()) text += fmt::format("  ; {}", m.signals[in.b].name);
        break;
      case Op::kField:
      case Op::kLastField:
      case Op::kSubstField:
        text += fmt::format(" {}", in.b);
        break;
      case Op::kSubstBegin:
        text += in.b == core::kNone ? std::string(" <checked>") : fmt::format(" cmd{}", in.b);
        break;
      case Op::kJumpIfZero:
      case Op::kJump:
        text += fmt::format(" +{}  ; -> {}", in.imm, static_cast<int64_t>(pc) + in.imm);
        break;
      default:
        break;
    }
    out += fmt::format("      {:4}  {}\n", pc, text);
  }
}

}  // namespace

std::string dump(const ImageModel& m) {
  std::string out;
  out += fmt::format("tasks ({}):\n", m.tasks.size());
  for (size_t i = 0; i < m.tasks.size(); ++i) {
    const auto& t = m.tasks[i].record;
    out += fmt::format(
        "  t{} {}: period {}us deadline {}us wcet {}us priority {} "
        "actuations/job {} overhead {}ns\n",
        i, m.tasks[i].name, t.period_us, t.deadline_us, t.wcet_us, t.priority, t.actuations_per_job,
        t.overhead_ns);
  }
  out += fmt::format("devices ({}):\n", m.devices.size());
  for (size_t i = 0; i < m.devices.size(); ++i) {
    const auto& d = m.devices[i].record;
    out += fmt::format("  d{} {}: role {}{} profile {} i2c-{} 0x{:02x}{} commands {}+{} safe {}+{}",
                       i, m.devices[i].name, (d.role & core::kRoleActuator) ? "A" : "",
                       (d.role & core::kRoleSensor) ? "S" : "",
                       d.profile == core::Profile::kFrame         ? "frame"
                       : d.profile == core::Profile::kRegisterMap ? "regmap"
                                                                  : "?",
                       d.bus, d.addr, d.ten_bit ? " (10-bit)" : "", d.command_first,
                       d.command_count, d.safe_first, d.safe_count);
    if (d.profile == core::Profile::kFrame)
      out += fmt::format(" frame {}+{}", d.prefix_len, d.frame_len);
    if (d.profile == core::Profile::kRegisterMap) {
      out += fmt::format(" ai {}", d.auto_increment == core::AutoIncrement::kNever ? "never"
                                   : d.auto_increment == core::AutoIncrement::kAlways
                                       ? "always"
                                       : fmt::format("bit {} of 0x{:02x}", d.ai_bit, d.ai_reg));
    }
    if (d.latch_mode != core::LatchMode::kOff) {
      out += fmt::format(" latch after {}{} in {}us", d.latch_count,
                         d.latch_mode == core::LatchMode::kHoldSafeUnrepaired ? " unrepaired" : "",
                         d.latch_window_us);
    }
    if (d.broadcast != d.broadcast_target) {
      out += fmt::format(" broadcast cmd{} -> cmd{}", d.command_first + d.broadcast,
                         d.command_first + d.broadcast_target);
    }
    if (d.gated != 0) {
      out += fmt::format(" cmd{} only while bit {} of reg 0x{:02x}", d.command_first + d.gated - 1,
                         d.gate_bit, d.ai_reg);
    }
    if (d.sample_len != 0) {
      out += fmt::format(" sample {}B every {}us max age {}us", d.sample_len, d.sample_period_us,
                         d.max_sample_age_us);
    }
    out += "\n";
  }
  out += fmt::format("aliases ({}):\n", m.aliases.size());
  for (const auto& a : m.aliases) {
    out += fmt::format("  i2c-{} 0x{:02x} {} -> d{}\n", a.bus, a.addr,
                       a.kind == core::AliasKind::kAddress ? "address" : "general-call", a.device);
  }
  out += fmt::format("commands ({}):\n", m.commands.size());
  for (size_t i = 0; i < m.commands.size(); ++i) {
    const auto& c = m.commands[i].record;
    static const char* kClass[] = {"?", "actuate", "query", "forbidden"};
    const auto cls = static_cast<uint8_t>(c.command_class);
    out += fmt::format("  cmd{} {} (d{}, {}): match 0x{:02x}", i, m.commands[i].name, c.device,
                       kClass[cls < 4 ? cls : 0], c.match);
    if (c.group_len != 0) {
      out += fmt::format(" group {} x{} stride {}", c.group_len, c.repeat, c.stride);
    }
    out += " fields:";
    for (uint32_t f = c.field_first; f < uint32_t{c.field_first} + c.field_count; ++f) {
      if (f >= m.fields.size()) {
        out += " <outside FIELDS>";
        break;
      }
      const auto& fr = m.fields[f].record;
      out += fmt::format(" {}@{}:{}b>>{}&{}{}{}", m.fields[f].name, fr.offset, fr.nbytes, fr.shift,
                         fr.width, (fr.flags & core::kFieldBigEndian) ? "be" : "",
                         (fr.flags & core::kFieldSigned) ? "s" : "");
    }
    out += "\n";
  }
  out += fmt::format("signals ({}):\n", m.signals.size());
  for (size_t i = 0; i < m.signals.size(); ++i) {
    const auto& s = m.signals[i].record;
    if (s.kind == core::SignalKind::kRaw) {
      out += fmt::format("  s{} {}: raw d{} byte {} ({}B) valid [{}, {}]\n", i, m.signals[i].name,
                         s.device, s.field.offset, s.field.nbytes, s.valid_min, s.valid_max);
    } else {
      out += fmt::format("  s{} {}: derived, code {}+{}\n", i, m.signals[i].name, s.code_first,
                         s.code_len);
      disassemble(out, m, s.code_first, s.code_len);
    }
  }
  out += fmt::format("rates ({}):\n", m.rates.size());
  for (size_t i = 0; i < m.rates.size(); ++i) {
    const auto& r = m.rates[i].record;
    out += fmt::format("  r{} {}: t{} -> d{} max {} per job over [{}] else {}", i, m.rates[i].name,
                       r.task, r.device, r.max_per_job, mask_list(r.commands),
                       response_name(r.response));
    if (r.only_channel != 0) out += fmt::format(" channel {}", r.only_channel - 1);
    if (r.template_id != core::kNone) out += fmt::format(" tpl{}", r.template_id);
    if (r.response == core::Response::kReject) out += fmt::format(" errno {}", r.reply_errno);
    out += "\n";
  }
  out += fmt::format("invariants ({}):\n", m.invariants.size());
  for (size_t i = 0; i < m.invariants.size(); ++i) {
    const auto& v = m.invariants[i].record;
    out += fmt::format("  i{} {}: d{} over [{}] on fail {}", i, m.invariants[i].name, v.device,
                       mask_list(v.commands), response_name(v.response));
    if (v.template_id != core::kNone) out += fmt::format(" tpl{}", v.template_id);
    if (v.scope == core::StateScope::kTask) out += ", state per task";
    if (v.scope == core::StateScope::kSession) out += ", state per session";
    if (v.after_safe != 0) out += fmt::format(", state {} after the safe state", v.after_safe - 1);
    out += fmt::format(", code {}+{}\n", v.code_first, v.code_len);
    disassemble(out, m, v.code_first, v.code_len);
  }
  out += fmt::format("templates ({}):\n", m.templates.size());
  for (size_t i = 0; i < m.templates.size(); ++i) {
    const auto& t = m.templates[i];
    out += fmt::format(
        "  tpl{}: {}", i,
        t.command == core::kNone ? std::string("<checked>") : fmt::format("cmd{}", t.command));
    if (t.index != core::kSameIndex) out += fmt::format("[{}]", t.index);
    for (uint32_t f = 0; f < 8; ++f) {
      if ((t.set_mask >> f) & 1u) out += fmt::format(" f{}={}", f, t.values[f]);
    }
    out += "\n";
  }
  out += fmt::format("constants ({}):", m.constants.size());
  for (size_t i = 0; i < m.constants.size(); ++i) out += fmt::format(" c{}={}", i, m.constants[i]);
  out += "\n";
  out += fmt::format("access ({} tasks):\n", m.access.size());
  for (size_t i = 0; i < m.access.size(); ++i) {
    out += fmt::format("  t{}: actuate 0x{:08x} read 0x{:08x}\n", i, m.access[i].actuate_devices,
                       m.access[i].read_devices);
  }
  out += fmt::format("register init ({}):", m.register_init.size());
  for (const auto& r : m.register_init) {
    out += fmt::format(" d{}[0x{:02x}]=0x{:02x}", r.device, r.reg, r.value);
  }
  out += "\n";
  return out;
}

}  // namespace contego::image
