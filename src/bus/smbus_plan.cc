#include "bus/smbus_plan.h"

#include <errno.h>

#include <algorithm>
#include <array>
#include <cstdio>

#include "contego/i2c_plan.h"

namespace contego::bus {
namespace {

std::string hex(uint64_t v, int width = 2) {
  char buf[24];
  (void)std::snprintf(buf, sizeof buf, "0x%0*llx", width, static_cast<unsigned long long>(v));
  return buf;
}

// A human description of the transfer, for refusals.
std::string describe(std::span<const Msg> msgs) {
  std::string out;
  for (const Msg& m : msgs) {
    if (!out.empty()) out += " + ";
    out += (m.flags & kMsgRead) ? "read " : "write ";
    out += (m.flags & kMsgRecvLen) ? std::string("RECV_LEN") : std::to_string(m.len);
  }
  return (msgs.size() == 1 ? "" : "[") + out + (msgs.size() == 1 ? "" : "]") + " at " +
         hex(msgs.empty() ? 0 : msgs[0].addr);
}

}  // namespace

std::string refusal_reason(std::span<const Msg> msgs, uint64_t funcs, const contego_i2c_plan& p) {
  switch (p.refusal) {
    case CONTEGO_I2C_NO_MESSAGES:
      return contego_i2c_refusal_text(p.refusal);
    case CONTEGO_I2C_NO_ZERO_LENGTH:
      return describe(msgs) +
             ": the adapter cannot send a zero-length message (no quick command in I2C_FUNCS " +
             hex(funcs, 8) + ")";
    case CONTEGO_I2C_FLAGS:
      return describe(msgs) + ": message flags " + hex(p.flags, 4) +
             " need an adapter with plain I2C";
    case CONTEGO_I2C_NO_FORM: {
      std::string names;
      for (uint32_t i = 0; i < p.candidate_count; ++i) {
        if (!names.empty()) names += ", ";
        names += contego_smbus_name(p.candidates[i], p.candidates_read);
      }
      return describe(msgs) + ": the adapter has no plain I2C and no " +
             (p.candidate_count == 1 ? "" : "one of ") + names + " (I2C_FUNCS " + hex(funcs, 8) +
             ")";
    }
    default:
      return describe(msgs) + ": " + contego_i2c_refusal_text(p.refusal);
  }
}

const char* smbus_name(SmbusSize size, bool read) {
  return contego_smbus_name(static_cast<uint32_t>(size), read ? 1 : 0);
}

Plan plan_transfer(std::span<const Msg> msgs, uint64_t funcs) {
  // The shared planner takes struct i2c_msg's layout; a transfer longer
  // than I2C_RDWR allows has no form anywhere.
  constexpr size_t kMax = 42;
  Plan plan;
  if (msgs.size() > kMax) {
    plan.reason = describe(msgs) + ": more than 42 messages";
    return plan;
  }
  contego_i2c_msg raw[kMax];
  for (size_t i = 0; i < msgs.size(); ++i) {
    raw[i] = {msgs[i].addr, msgs[i].flags, msgs[i].len, msgs[i].buf};
  }
  contego_i2c_plan p{};
  contego_i2c_plan_transfer(raw, static_cast<uint32_t>(msgs.size()), funcs, &p);
  if (p.form == CONTEGO_I2C_FORM_I2C) {
    plan.form = Plan::Form::kI2c;
  } else if (p.form == CONTEGO_I2C_FORM_SMBUS) {
    plan.form = Plan::Form::kSmbus;
    plan.op.addr = p.op.addr;
    plan.op.read = p.op.read != 0;
    plan.op.command = p.op.command;
    plan.op.size = static_cast<SmbusSize>(p.op.size);
    plan.op.reply = p.op.reply;
    std::copy_n(p.op.data, plan.op.data.size(), plan.op.data.begin());
  } else {
    plan.reason = refusal_reason(msgs, funcs, p);
  }
  return plan;
}

int deliver_reply(const SmbusOp& op, const std::array<uint8_t, 34>& data, std::span<Msg> msgs) {
  if (op.reply < 0) return 0;
  if (static_cast<size_t>(op.reply) >= msgs.size()) return EINVAL;
  // The shared model's, on the one message that receives the reply.
  contego_smbus_op raw{};
  raw.size = static_cast<uint8_t>(op.size);
  std::copy_n(op.data.begin(), op.data.size(), raw.data);
  Msg& m = msgs[static_cast<size_t>(op.reply)];
  contego_i2c_msg reply{m.addr, m.flags, m.len, m.buf};
  const int err = contego_i2c_deliver_reply(&raw, data.data(), &reply, 1);
  m.len = reply.len;
  return err;
}

Status Bus::expressible(std::span<const Msg> msgs) const {
  Plan p = plan_transfer(msgs, funcs());
  if (p.form == Plan::Form::kRefused) return make_error(std::move(p.reason));
  return {};
}

}  // namespace contego::bus
