// Object-dictionary indices and values that Cairn's master and emulated drive both use,
// named once (CiA 301 communication profile, CiA 402 drive profile). Names follow
// CANopenNode's object dictionary (OD_H1017_PRODUCER_HB, ...). Facts:
// ../shared/docs/protocols.md §2.4 and §2.5.
#pragma once

#include <cstdint>

namespace cairn::canopen::od {

// ---- CiA 301 communication profile
inline constexpr std::uint16_t kDeviceType = 0x1000;          // u32, const
inline constexpr std::uint16_t kErrorRegister = 0x1001;       // u8
inline constexpr std::uint16_t kDeviceName = 0x1008;          // visible string (manufacturer device name)
inline constexpr std::uint16_t kProducerHeartbeat = 0x1017;   // u16, ms (0 = off)

// PDO parameters; k is 0-based (k = 0 is RPDO1 / TPDO1), k < 4 for the predefined COB-IDs.
constexpr std::uint16_t rpdo_communication(unsigned k) { return static_cast<std::uint16_t>(0x1400 + k); }
constexpr std::uint16_t rpdo_mapping(unsigned k) { return static_cast<std::uint16_t>(0x1600 + k); }
constexpr std::uint16_t tpdo_communication(unsigned k) { return static_cast<std::uint16_t>(0x1800 + k); }
constexpr std::uint16_t tpdo_mapping(unsigned k) { return static_cast<std::uint16_t>(0x1A00 + k); }
// Sub-indices of a communication parameter (0x1400+k / 0x1800+k) and of a mapping (0x1600+k / 0x1A00+k).
inline constexpr std::uint8_t kPdoCobId = 1;             // u32
inline constexpr std::uint8_t kPdoTransmissionType = 2;  // u8
inline constexpr std::uint8_t kPdoMappingCount = 0;      // u8: number of mapped objects; entries at 1..count (u32)
inline constexpr std::uint32_t kPdoDisabled = 0x80000000u;  // COB-ID bit 31: the PDO is not valid
// Transmission types: 1..240 = synchronous, on every n-th SYNC; 254/255 = event-driven.
inline constexpr std::uint8_t kTransmissionEverySync = 1;
inline constexpr std::uint8_t kTransmissionEventDriven = 255;  // device-profile specific

// Bits of the error register (0x1001).
namespace error_register {
inline constexpr std::uint8_t kGeneric = 0x01;
inline constexpr std::uint8_t kCurrent = 0x02;
}  // namespace error_register

// ---- CiA 402 drive profile
inline constexpr std::uint16_t kControlword = 0x6040;            // u16
inline constexpr std::uint16_t kStatusword = 0x6041;             // u16
inline constexpr std::uint16_t kModesOfOperation = 0x6060;       // i8 (cia402::Mode)
inline constexpr std::uint16_t kModesOfOperationDisplay = 0x6061;  // i8
inline constexpr std::uint16_t kPositionActual = 0x6064;         // i32, increments
inline constexpr std::uint16_t kVelocityActual = 0x606C;         // i32, increments/s
inline constexpr std::uint16_t kProfileAcceleration = 0x6083;    // u32
inline constexpr std::uint16_t kProfileDeceleration = 0x6084;    // u32
inline constexpr std::uint16_t kQuickStopDeceleration = 0x6085;  // u32
inline constexpr std::uint16_t kTargetVelocity = 0x60FF;         // i32, increments/s
inline constexpr std::uint16_t kSupportedDriveModes = 0x6502;    // u32 bitmask

// Bits of the supported drive modes (0x6502).
namespace drive_modes {
inline constexpr std::uint32_t kProfileVelocity = 1u << 2;
inline constexpr std::uint32_t kCyclicSyncVelocity = 1u << 8;
}  // namespace drive_modes

}  // namespace cairn::canopen::od
