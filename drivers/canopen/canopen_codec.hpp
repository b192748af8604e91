// CANopen (CiA 301) frames as values: NMT, SYNC, heartbeat, EMCY, expedited and segmented
// SDO, PDOs; abort and EMCY codes as text. Pure: frames in, typed values out; no I/O,
// no clock, no heap. Facts: ../shared/docs/protocols.md §2.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>

#include "drivers/can/can_port.hpp"

namespace cairn::canopen {

using can::Frame;

// ---- COB-IDs
inline constexpr std::uint32_t kCobNmt = 0x000, kCobSync = 0x080, kCobEmcy = 0x080;
inline constexpr std::uint32_t kCobTpdo[4] = {0x180, 0x280, 0x380, 0x480};  // + node: drive -> master
inline constexpr std::uint32_t kCobRpdo[4] = {0x200, 0x300, 0x400, 0x500};  // + node: master -> drive
inline constexpr std::uint32_t kCobSdoTx = 0x580, kCobSdoRx = 0x600, kCobHeartbeat = 0x700;

enum class NmtCommand : std::uint8_t { kStart = 0x01, kStop = 0x02, kPreOperational = 0x80, kResetNode = 0x81, kResetComm = 0x82 };
enum class NmtState : std::uint8_t { kBootUp = 0x00, kStopped = 0x04, kOperational = 0x05, kPreOperational = 0x7F };
const char* nmt_state_name(NmtState s);

Frame nmt(NmtCommand cmd, std::uint8_t node);  // node 0 = all
Frame sync(std::optional<std::uint8_t> counter = std::nullopt);
Frame heartbeat(std::uint8_t node, NmtState state);

/// What kind of frame a COB-ID is, and for which node.
enum class Kind : std::uint8_t { kNmt, kSync, kEmcy, kTpdo, kRpdo, kSdoResponse, kSdoRequest, kHeartbeat, kOther };
struct Classified {
  Kind kind = Kind::kOther;
  std::uint8_t node = 0;
  std::uint8_t pdo = 0;  // 0..3 for PDOs
};
Classified classify(std::uint32_t cob_id);
/// CANopen (CiA 301) uses 11-bit data frames only: false for extended (29-bit), remote
/// (RTR) and error frames, which must never be taken for a PDO, SDO, heartbeat or EMCY
/// even when their low 11 bits match a COB-ID.
constexpr bool is_standard_data_frame(const Frame& f) {
  return !(f.id & (Frame::kExtended | Frame::kRemote | Frame::kError));
}

struct Heartbeat {
  std::uint8_t node = 0;
  NmtState state = NmtState::kBootUp;
};
std::optional<Heartbeat> decode_heartbeat(const Frame& f);

struct Emcy {
  std::uint8_t node = 0;
  std::uint16_t code = 0;  // 0x0000 = error reset / no error
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> vendor{};
};
std::optional<Emcy> decode_emcy(const Frame& f);
Frame encode_emcy(std::uint8_t node, std::uint16_t code, std::uint8_t error_register);
/// The CiA 301 / 402 class of an EMCY code ("current", "voltage", "temperature", ...).
const char* emcy_text(std::uint16_t code);

// ---- SDO (client side builds requests and reads responses; the server the reverse)
inline constexpr std::uint8_t kSdoAbort = 0x80;
// SDO abort codes (CiA 301 §7.2.4.3.17): the one source of truth for the master, the
// emulated drive and the tests. Names follow CANopenNode's CO_SDO_abortCode_t.
namespace abort_code {
inline constexpr std::uint32_t kToggleBit = 0x05030000;  // CO_SDO_AB_TOGGLE_BIT
inline constexpr std::uint32_t kTimeout = 0x05040000;  // CO_SDO_AB_TIMEOUT
inline constexpr std::uint32_t kCommand = 0x05040001;  // CO_SDO_AB_CMD
inline constexpr std::uint32_t kOutOfMemory = 0x05040005;  // CO_SDO_AB_OUT_OF_MEM
inline constexpr std::uint32_t kUnsupportedAccess = 0x06010000;  // CO_SDO_AB_UNSUPPORTED_ACCESS
inline constexpr std::uint32_t kWriteOnly = 0x06010001;  // CO_SDO_AB_WRITEONLY
inline constexpr std::uint32_t kReadOnly = 0x06010002;  // CO_SDO_AB_READONLY
inline constexpr std::uint32_t kNotExist = 0x06020000;  // CO_SDO_AB_NOT_EXIST
inline constexpr std::uint32_t kNoMap = 0x06040041;  // CO_SDO_AB_NO_MAP
inline constexpr std::uint32_t kMapLength = 0x06040042;  // CO_SDO_AB_MAP_LEN
inline constexpr std::uint32_t kParameterIncompatible = 0x06040043;  // CO_SDO_AB_PRAM_INCOMPAT
inline constexpr std::uint32_t kDeviceIncompatible = 0x06040047;  // CO_SDO_AB_DEVICE_INCOMPAT
inline constexpr std::uint32_t kHardware = 0x06060000;  // CO_SDO_AB_HW
inline constexpr std::uint32_t kTypeMismatch = 0x06070010;  // CO_SDO_AB_TYPE_MISMATCH
inline constexpr std::uint32_t kDataTooLong = 0x06070012;  // CO_SDO_AB_DATA_LONG
inline constexpr std::uint32_t kDataTooShort = 0x06070013;  // CO_SDO_AB_DATA_SHORT
inline constexpr std::uint32_t kSubUnknown = 0x06090011;  // CO_SDO_AB_SUB_UNKNOWN
inline constexpr std::uint32_t kInvalidValue = 0x06090030;  // CO_SDO_AB_INVALID_VALUE
inline constexpr std::uint32_t kValueTooHigh = 0x06090031;  // CO_SDO_AB_VALUE_HIGH
inline constexpr std::uint32_t kValueTooLow = 0x06090032;  // CO_SDO_AB_VALUE_LOW
inline constexpr std::uint32_t kMaxLessThanMin = 0x06090036;  // CO_SDO_AB_MAX_LESS_MIN
inline constexpr std::uint32_t kNoResource = 0x060A0023;  // CO_SDO_AB_NO_RESOURCE
inline constexpr std::uint32_t kGeneral = 0x08000000;  // CO_SDO_AB_GENERAL
inline constexpr std::uint32_t kDataTransfer = 0x08000020;  // CO_SDO_AB_DATA_TRANSF
inline constexpr std::uint32_t kDataLocalControl = 0x08000021;  // CO_SDO_AB_DATA_LOC_CTRL
inline constexpr std::uint32_t kDataDeviceState = 0x08000022;  // CO_SDO_AB_DATA_DEV_STATE
inline constexpr std::uint32_t kDataObjectDictionary = 0x08000023;  // CO_SDO_AB_DATA_OD
inline constexpr std::uint32_t kNoData = 0x08000024;  // CO_SDO_AB_NO_DATA
}  // namespace abort_code
struct AbortCodeText {
  std::uint32_t code;
  const char* text;
};
/// Every named abort code with its text (what sdo_abort_text() reads).
extern const std::array<AbortCodeText, 28> kAbortCodeTexts;
const char* sdo_abort_text(std::uint32_t code);  // "unknown abort code" for the rest

struct SdoAddress {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
};

/// Expedited download (write) of 1..4 bytes.
Frame sdo_download(std::uint8_t node, SdoAddress a, std::span<const std::uint8_t> data);
Frame sdo_upload(std::uint8_t node, SdoAddress a);
Frame sdo_abort(std::uint32_t cob_id, SdoAddress a, std::uint32_t code);
/// Segment requests of a segmented transfer (toggle t).
Frame sdo_upload_segment(std::uint8_t node, bool toggle);
Frame sdo_download_initiate(std::uint8_t node, SdoAddress a, std::uint32_t size);  // segmented, size indicated
Frame sdo_download_segment(std::uint8_t node, bool toggle, std::span<const std::uint8_t> chunk, bool last);

// Server side: the responses on 0x580 + node that decode_sdo_response reads (an abort is
// sdo_abort(kCobSdoTx + node, ...)).
Frame sdo_download_ack(std::uint8_t node, SdoAddress a);  // initiate download response
Frame sdo_download_segment_ack(std::uint8_t node, bool toggle);
/// Expedited upload response: the low n bytes of `value` (n = 1..4, clamped), size indicated.
Frame sdo_upload_expedited(std::uint8_t node, SdoAddress a, std::uint32_t value, std::uint8_t n);
/// Initiate upload response of a segmented transfer of `size` bytes (size indicated).
Frame sdo_upload_segmented_init(std::uint8_t node, SdoAddress a, std::uint32_t size);
/// Upload segment response: up to 7 bytes of `chunk`, toggle t, last = no more segments.
Frame sdo_upload_segment_response(std::uint8_t node, bool toggle, std::span<const std::uint8_t> chunk, bool last);

struct SdoResponse {
  enum class Type : std::uint8_t {
    kDownloadAck, kUploadExpedited, kUploadSegmentedInit, kUploadSegment, kDownloadSegmentAck, kAbort, kInvalid
  };
  Type type = Type::kInvalid;
  SdoAddress address;
  std::uint32_t value = 0;             // expedited data (LE) or segmented size
  std::uint8_t size = 0;               // expedited: bytes valid; segment: bytes in `segment`
  bool toggle = false, last = false;
  std::array<std::uint8_t, 7> segment{};
  std::uint32_t abort_code = 0;
};
SdoResponse decode_sdo_response(const Frame& f);

// ---- PDO values (little-endian fields packed in order)
struct PdoField {
  std::uint8_t bits = 0;  // 8, 16, 32
  bool is_signed = false;
};
/// Packs values into a PDO payload; false if they do not fit 8 bytes.
bool pack_pdo(std::span<const PdoField> fields, std::span<const std::int64_t> values, Frame* f);
bool unpack_pdo(const Frame& f, std::span<const PdoField> fields, std::span<std::int64_t> values);
/// A mapping entry as written to 0x1600+k / 0x1A00+k: (index << 16) | (sub << 8) | bits.
constexpr std::uint32_t mapping_entry(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) {
  return (static_cast<std::uint32_t>(index) << 16) | (static_cast<std::uint32_t>(sub) << 8) | bits;
}

}  // namespace cairn::canopen
