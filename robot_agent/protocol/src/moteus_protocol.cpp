#include "cpgmatch/robot/moteus_protocol.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "cpgmatch/robot/odrive_protocol.hpp"  // kPi

namespace cpgmatch::robot {
namespace {

constexpr std::uint8_t kNop = 0x50;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::size_t type_size(MoteusType t) { return t == MoteusType::kInt8 ? 1 : t == MoteusType::kInt16 ? 2 : 4; }

std::int64_t type_min(MoteusType t) {
  switch (t) {
    case MoteusType::kInt8: return std::numeric_limits<std::int8_t>::min();
    case MoteusType::kInt16: return std::numeric_limits<std::int16_t>::min();
    default: return std::numeric_limits<std::int32_t>::min();
  }
}
std::int64_t type_max(MoteusType t) { return -type_min(t) - 1; }

bool is_angle(std::uint32_t reg) {
  return reg == kMoteusPosition || reg == kMoteusVelocity || reg == kMoteusCommandPosition ||
         reg == kMoteusCommandVelocity || reg == kMoteusSetOutputExact;
}

// The size of one integer unit of a register in moteus' own units (rev, rev/s, N m, scale); 1 for
// registers that hold plain integers (mode, fault).
double int_scale(std::uint32_t reg, MoteusType t) {
  const int i = static_cast<int>(t);
  switch (reg) {
    case kMoteusPosition: case kMoteusCommandPosition: case kMoteusSetOutputExact:
      return std::array<double, 3>{0.01, 0.0001, 0.00001}[i];
    case kMoteusVelocity: case kMoteusCommandVelocity:
      return std::array<double, 3>{0.1, 0.00025, 0.00001}[i];
    case kMoteusTorque: case kMoteusCommandTorque:
      return std::array<double, 3>{0.5, 0.01, 0.001}[i];
    case kMoteusKpScale: case kMoteusKdScale:
      return std::array<double, 3>{1.0 / 127, 1.0 / 32767, 1.0 / 2147483647}[i];
    default: return 1.0;
  }
}

// Subframes into a frame's data, padded with NOPs to a CAN-FD length at the end. Overflow (more than
// 64 bytes) marks the frame incomplete instead of writing past it.
class Writer {
 public:
  explicit Writer(can::CanFrame& f) : f_(f) {}
  void byte(std::uint8_t b) {
    if (at_ >= can::kMaxFdDataLength) {
      overflow_ = true;
      return;
    }
    f_.data[at_++] = b;
  }
  void varuint(std::uint32_t v) {
    do {
      const std::uint8_t low = v & 0x7F;
      v >>= 7;
      byte(static_cast<std::uint8_t>(low | (v ? 0x80 : 0)));
    } while (v);
  }
  // A subframe header: opcode family (0x00 write, 0x10 read, 0x20 reply), type, count, start register.
  void header(std::uint8_t family, MoteusType type, std::uint32_t count, std::uint32_t start) {
    const std::uint8_t op = static_cast<std::uint8_t>(family | (static_cast<std::uint8_t>(type) << 2));
    if (count >= 1 && count <= 3) {
      byte(static_cast<std::uint8_t>(op | count));
    } else {
      byte(op);
      varuint(count);
    }
    varuint(start);
  }
  // One register value in SI, converted to moteus' unit and the type's encoding.
  void value(std::uint32_t reg, MoteusType type, double si) {
    double v = is_angle(reg) ? odrive_rad_to_rev(si) : si;
    if (type == MoteusType::kFloat) {
      const auto u = std::bit_cast<std::uint32_t>(static_cast<float>(v));
      for (int i = 0; i < 4; ++i) byte(static_cast<std::uint8_t>(u >> (8 * i)));
      return;
    }
    std::int64_t raw = type_min(type);  // NaN
    if (!std::isnan(v)) {
      raw = std::clamp<std::int64_t>(std::llround(v / int_scale(reg, type)), type_min(type) + 1, type_max(type));
    }
    const auto u = static_cast<std::uint64_t>(raw);
    for (std::size_t i = 0; i < type_size(type); ++i) byte(static_cast<std::uint8_t>(u >> (8 * i)));
  }
  void finish() {
    const std::size_t length = can::fd_length_for(at_);
    while (at_ < length) f_.data[at_++] = kNop;
    f_.length = static_cast<std::uint8_t>(length);
  }
  bool overflow() const { return overflow_; }

 private:
  can::CanFrame& f_;
  std::size_t at_ = 0;
  bool overflow_ = false;
};

class Reader {
 public:
  explicit Reader(const can::CanFrame& f) : f_(f) {}
  bool done() const { return at_ >= f_.length; }
  bool ok() const { return ok_; }
  std::uint8_t byte() {
    if (at_ >= f_.length) {
      ok_ = false;
      return 0;
    }
    return f_.data[at_++];
  }
  std::uint32_t varuint() {
    std::uint32_t v = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      const std::uint8_t b = byte();
      v |= std::uint32_t{b & 0x7Fu} << shift;
      if (!(b & 0x80)) return v;
    }
    ok_ = false;
    return 0;
  }
  // One value of `type` for register `reg`, in SI.
  double value(std::uint32_t reg, MoteusType type) {
    std::uint64_t u = 0;
    for (std::size_t i = 0; i < type_size(type); ++i) u |= std::uint64_t{byte()} << (8 * i);
    if (type == MoteusType::kFloat) return moteus_decode_value(reg, type, 0, std::bit_cast<float>(static_cast<std::uint32_t>(u)));
    const int bits = static_cast<int>(8 * type_size(type));
    const std::int64_t raw = static_cast<std::int64_t>(u << (64 - bits)) >> (64 - bits);  // sign-extend
    return moteus_decode_value(reg, type, raw, 0.0f);
  }

 private:
  const can::CanFrame& f_;
  std::size_t at_ = 0;
  bool ok_ = true;
};

// Opcode parts: family (high nibble), type, count (0: a varuint follows).
struct Op {
  std::uint8_t family;
  MoteusType type;
  std::uint32_t count;
};
Op split(std::uint8_t op) { return {static_cast<std::uint8_t>(op & 0xF0), static_cast<MoteusType>((op >> 2) & 3), op & 3u}; }

void assign(MoteusRequest& r, std::uint32_t reg, double v) {
  switch (reg) {
    case kMoteusMode: r.mode = static_cast<int>(v); break;
    case kMoteusCommandPosition: r.position_rad = v; break;
    case kMoteusCommandVelocity: r.velocity_rad_s = v; break;
    case kMoteusCommandTorque: r.torque_nm = v; break;
    case kMoteusKpScale: r.kp_scale = v; break;
    case kMoteusKdScale: r.kd_scale = v; break;
    case kMoteusSetOutputExact: r.set_output_rad = v; break;
    default: break;  // other registers: a real servo has them; the twin ignores them
  }
}

double state_value(const MoteusState& s, std::uint32_t reg) {
  switch (reg) {
    case kMoteusMode: return s.mode;
    case kMoteusPosition: return s.position_rad;
    case kMoteusVelocity: return s.velocity_rad_s;
    case kMoteusTorque: return s.torque_nm;
    case kMoteusFault: return s.fault;
    default: return 0.0;
  }
}

}  // namespace

double moteus_decode_value(std::uint32_t reg, MoteusType type, std::int64_t raw_int, float raw_float) {
  double v;
  if (type == MoteusType::kFloat) {
    v = raw_float;
  } else {
    if (raw_int == type_min(type)) return kNaN;
    v = static_cast<double>(raw_int) * int_scale(reg, type);
  }
  return is_angle(reg) ? odrive_rev_to_rad(v) : v;
}

std::optional<MoteusRequest> moteus_parse_request(const can::CanFrame& f) {
  if (!f.fd || f.remote || f.error) return std::nullopt;
  MoteusRequest r;
  r.reply_requested = (f.id & kMoteusReplyRequested) != 0;
  Reader in(f);
  while (!in.done() && in.ok()) {
    const std::uint8_t byte = in.byte();
    if (byte == kNop) continue;
    Op op = split(byte);
    if (op.family != 0x00 && op.family != 0x10) return std::nullopt;
    if (op.count == 0) op.count = in.varuint();
    const std::uint32_t start = in.varuint();
    if (op.count > 64) return std::nullopt;
    if (op.family == 0x00) {
      for (std::uint32_t i = 0; i < op.count; ++i) assign(r, start + i, in.value(start + i, op.type));
    } else {
      if (r.read_count >= r.reads.size()) return std::nullopt;
      r.reads[r.read_count++] = {start, op.count, op.type};
    }
  }
  if (!in.ok()) return std::nullopt;
  return r;
}

can::CanFrame moteus_encode_reply(std::uint32_t servo, std::uint32_t host, const MoteusRequest& request,
                                  const MoteusState& state) {
  can::CanFrame f;
  f.id = moteus_reply_id(servo, host);
  f.extended = true;
  f.fd = true;
  f.bit_rate_switch = true;
  Writer out(f);
  for (std::size_t k = 0; k < request.read_count; ++k) {
    const MoteusRequest::Read& read = request.reads[k];
    out.header(0x20, read.type, read.count, read.start);
    for (std::uint32_t i = 0; i < read.count; ++i) out.value(read.start + i, read.type, state_value(state, read.start + i));
  }
  out.finish();
  return f;
}

MoteusMotor::MoteusMotor(std::uint32_t servo_id, const MoteusSettings& settings) : servo_(servo_id), settings_(settings) {
  if (servo_id < 1 || servo_id > kMoteusMaxId) throw std::invalid_argument("moteus servo id must be in 1..127");
  if (settings.host_id > kMoteusMaxId) throw std::invalid_argument("moteus host id must be in 0..127");
}

can::CanFrame MoteusMotor::frame(int mode, double position_rad, double velocity_rad_s, double torque_nm,
                                 double kp_scale, double kd_scale) const {
  can::CanFrame f;
  f.id = moteus_command_id(settings_.host_id, servo_);
  f.extended = true;
  f.fd = true;
  f.bit_rate_switch = true;
  Writer out(f);
  out.header(0x00, MoteusType::kInt8, 1, kMoteusMode);
  out.value(kMoteusMode, MoteusType::kInt8, mode);
  if (mode == kMoteusModePosition) {
    out.header(0x00, MoteusType::kFloat, 5, kMoteusCommandPosition);
    out.value(kMoteusCommandPosition, MoteusType::kFloat, position_rad);
    out.value(kMoteusCommandVelocity, MoteusType::kFloat, velocity_rad_s);
    out.value(kMoteusCommandTorque, MoteusType::kFloat, torque_nm);
    out.value(kMoteusKpScale, MoteusType::kFloat, kp_scale);
    out.value(kMoteusKdScale, MoteusType::kFloat, kd_scale);
  }
  // The query: position, velocity, torque as floats; mode and fault code as int8.
  out.header(0x10, MoteusType::kFloat, 3, kMoteusPosition);
  out.header(0x10, MoteusType::kInt8, 1, kMoteusMode);
  out.header(0x10, MoteusType::kInt8, 1, kMoteusFault);
  out.finish();
  return f;
}

void MoteusMotor::command(const MotorCommand& c, FrameSink& out) {
  auto scale = [](double gain, double servo_gain) {
    if (!(servo_gain > 0.0) || !std::isfinite(gain)) return 0.0;
    return std::clamp(gain / servo_gain, 0.0, 1.0);
  };
  const double position = std::isfinite(c.position_rad) ? c.position_rad : 0.0;
  const double velocity = std::isfinite(c.velocity_rad_s) ? c.velocity_rad_s : 0.0;
  const double torque = std::isfinite(c.torque_nm) ? c.torque_nm : 0.0;
  out.push(frame(kMoteusModePosition, position, velocity, torque, scale(c.kp_nm_per_rad, settings_.servo_kp_nm_per_rad),
                 scale(c.kd_nm_s_per_rad, settings_.servo_kd_nm_s_per_rad)));
}

// Position mode with both scales 0: no torque at all until the first command; a NaN position holds the
// target at the measured one (moteus' own meaning of NaN here).
void MoteusMotor::enable(FrameSink& out) { out.push(frame(kMoteusModePosition, kNaN, 0.0, 0.0, 0.0, 0.0)); }

void MoteusMotor::disable(FrameSink& out) { out.push(frame(kMoteusModeStopped, 0.0, 0.0, 0.0, 0.0, 0.0)); }

void MoteusMotor::set_zero(FrameSink& out) {
  can::CanFrame f;
  f.id = moteus_command_id(settings_.host_id, servo_);
  f.extended = true;
  f.fd = true;
  f.bit_rate_switch = true;
  Writer w(f);
  w.header(0x00, MoteusType::kFloat, 1, kMoteusSetOutputExact);
  w.value(kMoteusSetOutputExact, MoteusType::kFloat, 0.0);
  w.finish();
  out.push(f);
}

FeedbackResult MoteusMotor::decode_feedback(const can::CanFrame& f) {
  FeedbackResult r;
  if (f.error || f.remote || f.id != moteus_reply_id(servo_, settings_.host_id)) return r;
  if (!f.fd) {  // a classic frame on this servo's reply id: not what a moteus sends
    r.status = FeedbackStatus::kWrongLength;
    return r;
  }
  bool have_position = false, have_velocity = false;
  int mode = -1;
  Reader in(f);
  r.feedback.node_id = servo_;
  while (!in.done() && in.ok()) {
    const std::uint8_t byte = in.byte();
    if (byte == kNop) continue;
    if (byte == 0x30 || byte == 0x31) {  // a register the servo could not write or read
      const std::uint32_t reg = in.varuint();
      const std::uint32_t code = in.varuint();
      r.fault = (reg << 16) | code;
      r.fault_kind = byte == 0x30 ? "register write error (register << 16 | code)" : "register read error (register << 16 | code)";
      continue;
    }
    Op op = split(byte);
    if (op.family != 0x20) {
      r.status = FeedbackStatus::kMalformed;
      return r;
    }
    if (op.count == 0) op.count = in.varuint();
    const std::uint32_t start = in.varuint();
    if (op.count > 64) break;
    for (std::uint32_t i = 0; i < op.count && in.ok(); ++i) {
      const std::uint32_t reg = start + i;
      const double v = in.value(reg, op.type);
      switch (reg) {
        case kMoteusMode: mode = std::isnan(v) ? -1 : static_cast<int>(v); break;
        case kMoteusPosition: r.feedback.position_rad = v; have_position = std::isfinite(v); break;
        case kMoteusVelocity: r.feedback.velocity_rad_s = v; have_velocity = std::isfinite(v); break;
        case kMoteusTorque: r.feedback.torque_nm = v; r.has_torque = std::isfinite(v); break;
        case kMoteusFault:
          if (!std::isnan(v) && v != 0.0) {
            r.fault = static_cast<std::uint32_t>(v);
            r.fault_kind = "fault code";
          }
          break;
        default: break;
      }
    }
  }
  if (!in.ok()) {
    r.status = FeedbackStatus::kMalformed;
    return r;
  }
  if (mode == kMoteusModeFault && r.fault == 0) {
    r.fault = kMoteusModeFault;
    r.fault_kind = "fault mode";
  }
  r.has_position = have_position && have_velocity;
  r.status = FeedbackStatus::kOk;
  return r;
}

void MoteusMotor::feedback_filters(std::vector<can::CanFilter>& out) const {
  const std::uint32_t id = moteus_reply_id(servo_, settings_.host_id);
  out.push_back({id, can::kMaxExtendedId, true});
  if (id <= can::kMaxStandardId) out.push_back({id, can::kMaxStandardId, false});
}

}  // namespace cpgmatch::robot
