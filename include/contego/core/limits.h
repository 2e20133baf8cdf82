// Fixed capacities of the trusted core.
//
// Every table in the checker is a fixed-size array sized by these limits, so
// the core never allocates and its memory footprint is known at build time.
// The image verifier refuses any image that exceeds one of them. Raising a
// limit changes sizeof(Checker) and nothing else.
#ifndef CONTEGO_CORE_LIMITS_H_
#define CONTEGO_CORE_LIMITS_H_

#include <stdint.h>

namespace contego::core {

inline constexpr uint32_t kMaxTasks = 32;            // task ids 0..31
inline constexpr uint32_t kMaxDevices = 32;          // actuators + sensors
inline constexpr uint32_t kMaxAliases = 16;          // extra (bus, addr) a device answers to
inline constexpr uint32_t kMaxCommandDefs = 128;     // decoded command kinds, all devices
inline constexpr uint32_t kMaxFieldsPerCommand = 8;  // named fields of one command
inline constexpr uint32_t kMaxFieldDefs = 512;       // all fields of all commands
inline constexpr uint32_t kMaxSignals = 64;          // raw + derived sensor signals
inline constexpr uint32_t kMaxRateLimits = 64;
inline constexpr uint32_t kMaxInvariants = 128;
inline constexpr uint32_t kMaxTemplates = 128;        // constant commands (fail-safe, safe states)
inline constexpr uint32_t kMaxSafeStateCommands = 4;  // templates per device safe state
inline constexpr uint32_t kMaxCodeWords = 8192;       // bytecode instructions, all programs
inline constexpr uint32_t kMaxProgramLength = 512;    // instructions of one program
inline constexpr uint32_t kMaxConstants = 256;        // 64-bit constant pool
inline constexpr uint32_t kMaxStackDepth = 32;        // evaluation stack of the interpreter
inline constexpr uint32_t kMaxRegisters = 256;        // register-map devices: 8-bit register space
inline constexpr uint32_t kMaxWriteBytes = 64;        // longest write transaction the core accepts
inline constexpr uint32_t kMaxSampleBytes = 64;       // longest sensor sample
inline constexpr uint32_t kMaxEmitBytes = 256;        // bytes a verdict may ask the host to write
inline constexpr uint32_t kMaxEmits = 64;             // separate bus writes in one verdict
inline constexpr uint32_t kMaxCommandsPerTransaction = 32;
inline constexpr uint32_t kMaxHistorySlots = 1024;  // "last command" memories: one per frame
                                                    // command, one per channel of a register group
inline constexpr uint32_t kMaxLatchCount = 16;      // K of "latch after K violations"
// A transfer (several transactions checked as one unit): the devices whose
// model it may change, and the "last command" memories it may overwrite.
inline constexpr uint32_t kMaxTransferDevices = 4;
inline constexpr uint32_t kMaxTransferHistory = 64;
inline constexpr uint32_t kMaxImageBytes = 256 * 1024;

}  // namespace contego::core

#endif  // CONTEGO_CORE_LIMITS_H_
