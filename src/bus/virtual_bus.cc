#include "bus/virtual_bus.h"

#include <errno.h>

#include <algorithm>

namespace contego::bus {

void VirtualBus::attach(std::shared_ptr<DeviceModel> device) {
  base::MutexLock lock(mu_);
  devices_.push_back(std::move(device));
}

DeviceModel* VirtualBus::find(uint16_t addr) const {
  for (const auto& d : devices_) {
    if (d->answers(addr)) return d.get();
  }
  return nullptr;
}

int VirtualBus::transfer(std::span<Msg> msgs) {
  // An adapter without plain I2C performs the SMBus form of the transfer:
  // the same bytes on the wire, so the models below see the same messages.
  if (carries_refused_flags(msgs)) return EINVAL;
  if (!expressible(msgs).ok()) return EOPNOTSUPP;
  base::MutexLock lock(mu_);
  ++operations_;
  for (Msg& m : msgs) {
    const bool read = (m.flags & kMsgRead) != 0;
    if ((m.flags & kMsgTen) != 0) return ENXIO;  // no ten-bit devices on the virtual bus
    if (m.addr == 0 && !read) {
      if (devices_.empty()) return ENXIO;
      for (const auto& d : devices_) d->general_call({m.buf, m.len});
      continue;
    }
    DeviceModel* d = find(m.addr);
    if (d == nullptr) return ENXIO;
    if (!read) {
      d->write(m.addr, {m.buf, m.len});
    } else if ((m.flags & kMsgRecvLen) != 0) {  // RECV_LEN: the first byte says how many follow
      if (m.len < 1) return EINVAL;
      d->read(m.addr, {m.buf, 1});
      const uint16_t count = m.buf[0];
      if (count == 0 || count > 32 || count + 1 > m.len) return EPROTO;
      d->read(m.addr, {m.buf + 1, count});
      m.len = static_cast<uint16_t>(count + 1);
    } else {
      d->read(m.addr, {m.buf, m.len});
    }
  }
  return 0;
}

int VirtualBus::quick(uint16_t addr, bool /*read*/) {
  if (!(funcs() & kFuncSmbusQuick)) return EOPNOTSUPP;
  base::MutexLock lock(mu_);
  ++operations_;
  return find(addr) != nullptr ? 0 : ENXIO;
}

uint64_t VirtualBus::operations() const {
  base::MutexLock lock(mu_);
  return operations_;
}

void VirtualBus::with_lock(const std::function<void()>& fn) {
  base::MutexLock lock(mu_);
  fn();
}

// --- PCA9685 -------------------------------------------------------------------

Pca9685::Pca9685(uint16_t addr) : addr_(addr) { reset(); }

void Pca9685::reset() {
  regs_.fill(0);
  regs_[0x00] = 0x11;  // SLEEP | ALLCALL
  regs_[0x01] = 0x04;  // OUTDRV
  regs_[0x02] = 0xE2;
  regs_[0x03] = 0xE4;
  regs_[0x04] = 0xE8;
  regs_[0x05] = 0xE0;
  for (int ch = 0; ch < 16; ++ch) regs_[0x09 + 4 * ch] = 0x10;  // full OFF at power-on
  regs_[0xFD] = 0x10;
  regs_[0xFE] = 0x1E;
  pointer_ = 0;
}

bool Pca9685::answers(uint16_t addr) const {
  if (addr == addr_) return true;
  const uint8_t mode1 = regs_[0x00];
  if ((mode1 & 0x01) && addr == (regs_[0x05] >> 1)) return true;  // LED all-call
  for (int k = 0; k < 3; ++k) {
    if ((mode1 & (0x08 >> k)) && addr == (regs_[0x02 + k] >> 1)) return true;
  }
  return false;
}

void Pca9685::general_call(std::span<const uint8_t> bytes) {
  if (bytes.size() == 1 && bytes[0] == 0x06) reset();  // SWRST
}

void Pca9685::store(uint8_t r, uint8_t value) {
  if (r == 0x00) {
    regs_[r] = static_cast<uint8_t>(value & 0x7F);  // writing RESTART restarts, it reads back 0
  } else if (r == 0xFE) {
    if (regs_[0x00] & 0x10) regs_[r] = std::max<uint8_t>(value, 3);  // only while SLEEP
  } else if (r >= 0xFA && r <= 0xFD) {
    for (int ch = 0; ch < 16; ++ch) regs_[0x06 + 4 * ch + (r - 0xFA)] = value;
    regs_[r] = value;
  } else {
    regs_[r] = value;
  }
}

void Pca9685::write(uint16_t /*addr*/, std::span<const uint8_t> bytes) {
  if (bytes.empty()) return;
  pointer_ = bytes[0];
  const bool ai = (regs_[0x00] & 0x20) != 0;
  for (size_t i = 1; i < bytes.size(); ++i) {
    store(pointer_, bytes[i]);
    if (ai) pointer_ = static_cast<uint8_t>(pointer_ + 1);
  }
}

void Pca9685::read(uint16_t /*addr*/, std::span<uint8_t> out) {
  const bool ai = (regs_[0x00] & 0x20) != 0;
  for (auto& b : out) {
    b = regs_[pointer_];
    if (ai) pointer_ = static_cast<uint8_t>(pointer_ + 1);
  }
}

uint16_t Pca9685::led_on(int channel) const {
  const int base = 0x06 + 4 * channel;
  return static_cast<uint16_t>(((regs_[base + 1] & 0x1F) << 8) | regs_[base]);
}

uint16_t Pca9685::led_off(int channel) const {
  const int base = 0x08 + 4 * channel;
  return static_cast<uint16_t>(((regs_[base + 1] & 0x1F) << 8) | regs_[base]);
}

// --- GoPiGo2 -------------------------------------------------------------------

void GoPiGo2::write(uint16_t /*addr*/, std::span<const uint8_t> bytes) {
  if (bytes.size() < 4) return;  // the firmware acts only when four bytes remain
  const auto f = bytes.last(4);
  std::copy(f.begin(), f.end(), last_.begin());
  ++frames_;
  const uint8_t cmd = f[0];
  auto two = [](uint16_t v) {
    return std::vector<uint8_t>{static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v & 0xFF)};
  };
  switch (cmd) {
    case 0x77:
    case 0x69:
    case 0x6B:
    case 0x73:
    case 0x61:
    case 0x62:
    case 0x64:
    case 0x6E:
    case 0x78:
      motion_ = cmd;
      break;
    case 0x74:
      speed1_ = speed1_ >= 245 ? 255 : static_cast<uint8_t>(speed1_ + 10);
      speed2_ = speed1_;
      break;
    case 0x67:
      speed1_ = speed1_ < 11 ? 0 : static_cast<uint8_t>(speed1_ - 10);
      speed2_ = speed1_;
      break;
    case 0x46:
      speed2_ = f[1];
      break;
    case 0x47:
      speed1_ = f[1];
      break;
    case 0x6F:
      speed1_ = f[2];
      motion_ = cmd;
      break;
    case 0x70:
      speed2_ = f[2];
      motion_ = cmd;
      break;
    case 0x32:
      encoder_target_ = true;
      encoder_ = {0, 0};
      break;
    case 0x35:
      reply_ = two(encoder_[f[1] & 1]);
      break;
    case 0x72:
      reply_ = {speed1_, speed2_};
      break;
    case 0x76:
      reply_ = two(983);
      break;  // about 12 V
    case 0x14:
      reply_ = {16, 0};
      break;
    case 0x50:
      com_timeout_ = true;
      break;
    case 0x51:
      com_timeout_ = false;
      break;
    default:
      break;
  }
}

void GoPiGo2::read(uint16_t /*addr*/, std::span<uint8_t> out) {
  for (auto& b : out) {
    if (!reply_.empty()) {
      b = reply_.front();
      reply_.erase(reply_.begin());
    } else {
      b = static_cast<uint8_t>((encoder_target_ ? 1 : 0) | (com_timeout_ ? 2 : 0));
    }
  }
}

// --- line follower -------------------------------------------------------------

void LineFollower::write(uint16_t /*addr*/, std::span<const uint8_t> bytes) {
  if (bytes.size() < 4 || bytes[bytes.size() - 4] != 3) return;
  const auto values = source_ ? source_() : values_;
  for (size_t i = 0; i < 5; ++i) {
    const uint16_t v = static_cast<uint16_t>(values[i] & 0x3FF);
    reply_[2 * i] = static_cast<uint8_t>(v >> 8);
    reply_[2 * i + 1] = static_cast<uint8_t>(v & 0xFF);
  }
  ++requests_;
}

void LineFollower::read(uint16_t /*addr*/, std::span<uint8_t> out) {
  for (size_t i = 0; i < out.size(); ++i) out[i] = i < reply_.size() ? reply_[i] : 0xFF;
}

}  // namespace contego::bus
