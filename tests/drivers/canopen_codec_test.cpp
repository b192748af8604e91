// CANopen frames against the byte layouts of ../shared/docs/protocols.md §2, and the
// CiA 402 state machine's decode table and command planning.
#include "drivers/canopen/canopen_codec.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "drivers/canopen/cia402.hpp"
#include "drivers/canopen/object_dictionary.hpp"
#include "drivers/canopen/pdo_map.hpp"

namespace cairn::canopen {
namespace {

std::vector<int> bytes(const Frame& f) { return {f.data.begin(), f.data.begin() + f.len}; }

TEST(CanopenFrames, NmtSyncHeartbeatEmcy) {
  const Frame start = nmt(NmtCommand::kStart, 5);
  EXPECT_EQ(start.id, 0x000u);
  EXPECT_EQ(bytes(start), (std::vector<int>{0x01, 0x05}));
  EXPECT_EQ(bytes(nmt(NmtCommand::kResetComm, 0)), (std::vector<int>{0x82, 0x00}));
  EXPECT_EQ(sync().id, 0x080u);
  EXPECT_EQ(sync().len, 0);
  EXPECT_EQ(bytes(sync(7)), (std::vector<int>{7}));

  const auto hb = decode_heartbeat(heartbeat(3, NmtState::kOperational));
  ASSERT_TRUE(hb);
  EXPECT_EQ(hb->node, 3);
  EXPECT_EQ(hb->state, NmtState::kOperational);
  Frame bootup = heartbeat(9, NmtState::kBootUp);
  EXPECT_EQ(bootup.id, 0x709u);
  EXPECT_EQ(decode_heartbeat(bootup)->state, NmtState::kBootUp);
  Frame bad = bootup;
  bad.data[0] = 0x33;
  EXPECT_FALSE(decode_heartbeat(bad));

  const Frame e = encode_emcy(2, 0x2310, 0x03);
  EXPECT_EQ(e.id, 0x082u);
  const auto emcy = decode_emcy(e);
  ASSERT_TRUE(emcy);
  EXPECT_EQ(emcy->code, 0x2310);
  EXPECT_EQ(emcy->error_register, 0x03);
  EXPECT_STREQ(emcy_text(0x2310), "output current (over-current)");
  EXPECT_STREQ(emcy_text(0x0000), "error reset / no error");
  Frame shortened = e;
  shortened.len = 4;
  EXPECT_FALSE(decode_emcy(shortened));
}

TEST(CanopenFrames, Classify) {
  EXPECT_EQ(classify(0x181).kind, Kind::kTpdo);
  EXPECT_EQ(classify(0x281).pdo, 1);
  EXPECT_EQ(classify(0x30A).kind, Kind::kRpdo);
  EXPECT_EQ(classify(0x30A).node, 10);
  EXPECT_EQ(classify(0x585).kind, Kind::kSdoResponse);
  EXPECT_EQ(classify(0x605).kind, Kind::kSdoRequest);
  EXPECT_EQ(classify(0x77F).kind, Kind::kHeartbeat);
  EXPECT_EQ(classify(0x7E5).kind, Kind::kOther);  // LSS (0x7E4/0x7E5) is outside 0x701..0x77F
  EXPECT_EQ(classify(0x080).kind, Kind::kSync);
  EXPECT_EQ(classify(0x081).kind, Kind::kEmcy);
}

TEST(CanopenSdo, ExpeditedRequestsAreByteExact) {
  const std::uint8_t four[] = {0x0F, 0x00, 0x00, 0x00}, two[] = {0x06, 0x00}, one[] = {0x03};
  EXPECT_EQ(bytes(sdo_download(1, {0x6040, 0}, four)), (std::vector<int>{0x23, 0x40, 0x60, 0x00, 0x0F, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_download(1, {0x6040, 0}, two)), (std::vector<int>{0x2B, 0x40, 0x60, 0x00, 0x06, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_download(1, {0x6060, 0}, one)), (std::vector<int>{0x2F, 0x60, 0x60, 0x00, 0x03, 0, 0, 0}));
  EXPECT_EQ(sdo_download(1, {0x6060, 0}, one).id, 0x601u);
  EXPECT_EQ(bytes(sdo_upload(4, {0x1000, 0})), (std::vector<int>{0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
}

Frame reply(std::initializer_list<int> b) {
  Frame f;
  f.id = 0x581;
  f.len = 8;
  int i = 0;
  for (int x : b) f.data[i++] = static_cast<std::uint8_t>(x);
  return f;
}

TEST(CanopenSdo, ResponsesDecode) {
  auto r = decode_sdo_response(reply({0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(r.type, SdoResponse::Type::kDownloadAck);
  EXPECT_EQ(r.address.index, 0x6040);
  r = decode_sdo_response(reply({0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0xFF, 0xFF}));
  EXPECT_EQ(r.type, SdoResponse::Type::kUploadExpedited);
  EXPECT_EQ(r.size, 4);
  EXPECT_EQ(r.value, 0xFFFF0192u);  // device type of a CiA 402 drive
  r = decode_sdo_response(reply({0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0xAA, 0xAA}));
  EXPECT_EQ(r.size, 2);
  EXPECT_EQ(r.value, 0x0237u);  // padding ignored
  r = decode_sdo_response(reply({0x4F, 0x61, 0x60, 0x00, 0x09, 0, 0, 0}));
  EXPECT_EQ(r.size, 1);
  EXPECT_EQ(r.value, 9u);
  r = decode_sdo_response(reply({0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0}));
  EXPECT_EQ(r.type, SdoResponse::Type::kUploadSegmentedInit);
  EXPECT_EQ(r.value, 20u);
  r = decode_sdo_response(reply({0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x02, 0x06}));
  EXPECT_EQ(r.type, SdoResponse::Type::kAbort);
  EXPECT_EQ(r.abort_code, abort_code::kNotExist);
  EXPECT_STREQ(sdo_abort_text(r.abort_code), "object does not exist in the object dictionary");
  r = decode_sdo_response(reply({0x1B, 0x4C, 0x4D, 0, 0, 0, 0, 0}));  // toggle 1, n = 5 unused (2 bytes), last
  EXPECT_EQ(r.type, SdoResponse::Type::kUploadSegment);
  EXPECT_TRUE(r.toggle);
  EXPECT_TRUE(r.last);
  EXPECT_EQ(r.size, 2);
  Frame short_frame = reply({0x60});
  short_frame.len = 3;
  EXPECT_EQ(decode_sdo_response(short_frame).type, SdoResponse::Type::kInvalid);
}

// The named abort codes are CiA 301's values (pinned here against the standard's table, the
// only place raw codes appear), each named once, each with its text.
TEST(CanopenCodec, AbortCodesAreTheCia301Values) {
  EXPECT_EQ(abort_code::kToggleBit, 0x05030000u);
  EXPECT_EQ(abort_code::kTimeout, 0x05040000u);
  EXPECT_EQ(abort_code::kCommand, 0x05040001u);
  EXPECT_EQ(abort_code::kUnsupportedAccess, 0x06010000u);
  EXPECT_EQ(abort_code::kReadOnly, 0x06010002u);
  EXPECT_EQ(abort_code::kNotExist, 0x06020000u);
  EXPECT_EQ(abort_code::kTypeMismatch, 0x06070010u);
  EXPECT_EQ(abort_code::kDataTooLong, 0x06070012u);
  EXPECT_EQ(abort_code::kSubUnknown, 0x06090011u);
  EXPECT_EQ(abort_code::kInvalidValue, 0x06090030u);
  EXPECT_EQ(abort_code::kGeneral, 0x08000000u);
  EXPECT_EQ(abort_code::kNoData, 0x08000024u);
  for (std::size_t i = 0; i < kAbortCodeTexts.size(); ++i) {
    EXPECT_STRNE(sdo_abort_text(kAbortCodeTexts[i].code), "unknown abort code") << std::hex << kAbortCodeTexts[i].code;
    EXPECT_STREQ(sdo_abort_text(kAbortCodeTexts[i].code), kAbortCodeTexts[i].text);
    for (std::size_t j = i + 1; j < kAbortCodeTexts.size(); ++j) EXPECT_NE(kAbortCodeTexts[i].code, kAbortCodeTexts[j].code);
  }
  EXPECT_STREQ(sdo_abort_text(0x12345678), "unknown abort code");
  // On the wire: little-endian in bytes 4..7.
  const Frame f = sdo_abort(0x601, {0x2000, 1}, abort_code::kNotExist);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x80, 0x00, 0x20, 0x01, 0x00, 0x00, 0x02, 0x06}));
}

TEST(CanopenSdo, SegmentedRequests) {
  EXPECT_EQ(bytes(sdo_upload_segment(1, false)), (std::vector<int>{0x60, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_upload_segment(1, true)), (std::vector<int>{0x70, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_download_initiate(1, {0x1008, 0}, 10)), (std::vector<int>{0x21, 0x08, 0x10, 0x00, 10, 0, 0, 0}));
  const std::uint8_t chunk[] = {'a', 'b', 'c'};
  EXPECT_EQ(bytes(sdo_download_segment(1, true, chunk, true)), (std::vector<int>{0x19, 'a', 'b', 'c', 0, 0, 0, 0}));
}

// The server's responses (what the emulated drive sends) against CiA 301's command bytes.
TEST(CanopenSdo, ServerResponsesAreByteExact) {
  EXPECT_EQ(sdo_download_ack(1, {0x6040, 0}).id, 0x581u);
  EXPECT_EQ(bytes(sdo_download_ack(1, {0x6040, 0})), (std::vector<int>{0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0}));
  // Expedited upload, size indicated: 0x43 | (4 - n) << 2, the unused bytes zero.
  EXPECT_EQ(bytes(sdo_upload_expedited(1, {0x1000, 0}, 0xFFFF0192, 4)), (std::vector<int>{0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0xFF, 0xFF}));
  EXPECT_EQ(bytes(sdo_upload_expedited(1, {0x1A00, 1}, 0x606C0020, 3)), (std::vector<int>{0x47, 0x00, 0x1A, 0x01, 0x20, 0x00, 0x6C, 0}));
  EXPECT_EQ(bytes(sdo_upload_expedited(1, {0x6041, 0}, 0x0237, 2)), (std::vector<int>{0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0, 0}));
  EXPECT_EQ(bytes(sdo_upload_expedited(1, {0x6061, 0}, 0xAB09, 1)), (std::vector<int>{0x4F, 0x61, 0x60, 0x00, 0x09, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_upload_segmented_init(2, {0x1008, 0}, 28)), (std::vector<int>{0x41, 0x08, 0x10, 0x00, 28, 0, 0, 0}));
  EXPECT_EQ(sdo_upload_segmented_init(2, {0x1008, 0}, 28).id, 0x582u);
  const std::uint8_t seven[] = {'C', 'a', 'i', 'r', 'n', ' ', 'e'}, one[] = {'x'};
  EXPECT_EQ(bytes(sdo_upload_segment_response(1, false, seven, false)), (std::vector<int>{0x00, 'C', 'a', 'i', 'r', 'n', ' ', 'e'}));
  EXPECT_EQ(bytes(sdo_upload_segment_response(1, true, one, true)), (std::vector<int>{0x1D, 'x', 0, 0, 0, 0, 0, 0}));  // 6 unused, last
  EXPECT_EQ(bytes(sdo_download_segment_ack(1, false)), (std::vector<int>{0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes(sdo_download_segment_ack(1, true)), (std::vector<int>{0x30, 0, 0, 0, 0, 0, 0, 0}));
}

// Each server response decodes (as the client reads it) to what it was built from.
TEST(CanopenSdo, ServerResponsesRoundTrip) {
  const SdoAddress a{0x1A01, 1};
  SdoResponse r = decode_sdo_response(sdo_download_ack(5, a));
  EXPECT_EQ(r.type, SdoResponse::Type::kDownloadAck);
  EXPECT_EQ(r.address.index, a.index);
  EXPECT_EQ(r.address.sub, a.sub);
  for (std::uint8_t n = 1; n <= 4; ++n) {
    const std::uint32_t value = 0xDEADBEEF;
    r = decode_sdo_response(sdo_upload_expedited(5, a, value, n));
    EXPECT_EQ(r.type, SdoResponse::Type::kUploadExpedited) << int{n};
    EXPECT_EQ(r.size, n);
    EXPECT_EQ(r.value, n == 4 ? value : value & ((1u << (8 * n)) - 1)) << int{n};
    EXPECT_EQ(r.address.index, a.index);
    EXPECT_EQ(r.address.sub, a.sub);
  }
  r = decode_sdo_response(sdo_upload_segmented_init(5, {0x1008, 0}, 300));
  EXPECT_EQ(r.type, SdoResponse::Type::kUploadSegmentedInit);
  EXPECT_EQ(r.value, 300u);
  EXPECT_EQ(r.address.index, 0x1008);
  const std::uint8_t text[] = {1, 2, 3, 4, 5, 6, 7};
  for (std::size_t n = 1; n <= 7; ++n) {
    for (const bool toggle : {false, true}) {
      for (const bool last : {false, true}) {
        r = decode_sdo_response(sdo_upload_segment_response(5, toggle, {text, n}, last));
        EXPECT_EQ(r.type, SdoResponse::Type::kUploadSegment);
        EXPECT_EQ(r.size, n);
        EXPECT_EQ(r.toggle, toggle);
        EXPECT_EQ(r.last, last);
        EXPECT_TRUE(std::equal(text, text + n, r.segment.begin())) << n;
      }
    }
  }
  for (const bool toggle : {false, true}) {
    r = decode_sdo_response(sdo_download_segment_ack(5, toggle));
    EXPECT_EQ(r.type, SdoResponse::Type::kDownloadSegmentAck);
    EXPECT_EQ(r.toggle, toggle);
  }
}

TEST(CanopenPdo, PackAndUnpackWithSignExtension) {
  const PdoField fields[] = {{16, false}, {32, true}, {8, true}};
  const std::int64_t in[] = {0x1237, -123456, -5};
  Frame f;
  ASSERT_TRUE(pack_pdo(fields, in, &f));
  EXPECT_EQ(f.len, 7);
  std::int64_t out[3] = {};
  ASSERT_TRUE(unpack_pdo(f, fields, out));
  EXPECT_EQ(out[0], 0x1237);
  EXPECT_EQ(out[1], -123456);
  EXPECT_EQ(out[2], -5);
  f.len = 4;  // too short for the mapping: refused, not read past the end
  EXPECT_FALSE(unpack_pdo(f, fields, out));
  const PdoField too_many[] = {{32, false}, {32, false}, {8, false}};
  const std::int64_t v3[] = {1, 2, 3};
  EXPECT_FALSE(pack_pdo(too_many, v3, &f));
  EXPECT_EQ(mapping_entry(0x6040, 0, 16), 0x60400010u);
}

// The named object-dictionary indices are CiA 301 / 402's (pinned here against the
// standards' tables, ../shared/docs/protocols.md §2.4-2.5).
TEST(CanopenObjectDictionary, IndicesAreTheCiaValues) {
  EXPECT_EQ(od::kDeviceType, 0x1000);
  EXPECT_EQ(od::kErrorRegister, 0x1001);
  EXPECT_EQ(od::kDeviceName, 0x1008);
  EXPECT_EQ(od::kProducerHeartbeat, 0x1017);
  EXPECT_EQ(od::rpdo_communication(0), 0x1400);
  EXPECT_EQ(od::rpdo_mapping(1), 0x1601);
  EXPECT_EQ(od::tpdo_communication(1), 0x1801);
  EXPECT_EQ(od::tpdo_mapping(3), 0x1A03);
  EXPECT_EQ(od::kPdoDisabled, 0x80000000u);
  EXPECT_EQ(od::kControlword, 0x6040);
  EXPECT_EQ(od::kStatusword, 0x6041);
  EXPECT_EQ(od::kModesOfOperation, 0x6060);
  EXPECT_EQ(od::kModesOfOperationDisplay, 0x6061);
  EXPECT_EQ(od::kPositionActual, 0x6064);
  EXPECT_EQ(od::kVelocityActual, 0x606C);
  EXPECT_EQ(od::kProfileAcceleration, 0x6083);
  EXPECT_EQ(od::kProfileDeceleration, 0x6084);
  EXPECT_EQ(od::kQuickStopDeceleration, 0x6085);
  EXPECT_EQ(od::kTargetVelocity, 0x60FF);
  EXPECT_EQ(od::kSupportedDriveModes, 0x6502);
  EXPECT_EQ(od::drive_modes::kProfileVelocity | od::drive_modes::kCyclicSyncVelocity, 0x0104u);
}

// What the master packs and unpacks, from the table.
TEST(CanopenPdoMap, FieldsSlotsAndCobIds) {
  const PdoFields tpdo1 = pdo_fields(pdo_map::kTpdo1);
  ASSERT_EQ(tpdo1.span().size(), 2u);
  EXPECT_EQ(tpdo1.fields[0].bits, 16);
  EXPECT_FALSE(tpdo1.fields[0].is_signed);
  EXPECT_EQ(tpdo1.fields[1].bits, 32);
  EXPECT_TRUE(tpdo1.fields[1].is_signed);
  EXPECT_EQ(slot(pdo_map::kTpdo1, od::kVelocityActual), 1u);
  EXPECT_EQ(slot(pdo_map::kTpdo1, od::kPositionActual), kMaxMappedObjects);  // not in TPDO1
  EXPECT_EQ(cob_id(pdo_map::kRpdo1, 5), 0x205u);
  EXPECT_EQ(cob_id(pdo_map::kTpdo2, 5), 0x285u);
  EXPECT_EQ(mapping_index(pdo_map::kTpdo2), 0x1A01);
  EXPECT_EQ(communication_index(pdo_map::kRpdo1), 0x1400);
  // A TPDO1 frame as a drive sends it: statusword 0x0637, velocity -123456.
  Frame f;
  f.len = 6;
  f.data = {0x37, 0x06, 0xC0, 0x1D, 0xFE, 0xFF, 0, 0};
  std::int64_t v[kMaxMappedObjects] = {};
  ASSERT_TRUE(unpack_pdo(f, tpdo1.span(), v));
  EXPECT_EQ(v[slot(pdo_map::kTpdo1, od::kStatusword)], 0x0637);
  EXPECT_EQ(v[slot(pdo_map::kTpdo1, od::kVelocityActual)], -123456);
}

using namespace cairn::cia402;

TEST(Cia402, DecodesEveryState) {
  EXPECT_EQ(decode(0x0000), State::kNotReadyToSwitchOn);
  EXPECT_EQ(decode(0x0040), State::kSwitchOnDisabled);
  EXPECT_EQ(decode(0x0250), State::kSwitchOnDisabled);  // with remote + voltage bits
  EXPECT_EQ(decode(0x0221), State::kReadyToSwitchOn);
  EXPECT_EQ(decode(0x0233), State::kSwitchedOn);
  EXPECT_EQ(decode(0x1637), State::kOperationEnabled);
  EXPECT_EQ(decode(0x0217), State::kQuickStopActive);
  EXPECT_EQ(decode(0x001F), State::kFaultReactionActive);
  EXPECT_EQ(decode(0x0218), State::kFault);
}

// A minimal drive following the CiA 402 transition table, to check the planner reaches its goal.
State apply(State s, std::uint16_t cw, std::uint16_t prev) {
  const bool reset_edge = (cw & 0x80) && !(prev & 0x80);
  if (s == State::kFault) return reset_edge ? State::kSwitchOnDisabled : s;
  if ((cw & 0x0002) == 0) return State::kSwitchOnDisabled;  // disable voltage
  if ((cw & 0x0006) == 0x0002) return s == State::kOperationEnabled ? State::kQuickStopActive : State::kSwitchOnDisabled;
  switch (cw & 0x000F) {
    case 0x6:
      return (s == State::kSwitchOnDisabled || s == State::kSwitchedOn || s == State::kOperationEnabled ||
              s == State::kReadyToSwitchOn)
                 ? State::kReadyToSwitchOn
                 : s;
    case 0x7: return (s == State::kReadyToSwitchOn || s == State::kOperationEnabled) ? State::kSwitchedOn : s;
    case 0xF: return (s == State::kSwitchedOn || s == State::kOperationEnabled) ? State::kOperationEnabled : s;
    default: return s;
  }
}

TEST(Cia402, PlannerReachesOperationEnabledFromEveryState) {
  for (State start : {State::kSwitchOnDisabled, State::kReadyToSwitchOn, State::kSwitchedOn, State::kOperationEnabled,
                      State::kQuickStopActive, State::kFault}) {
    State s = start;
    std::uint16_t last = 0x0080;  // worst case for a fault: bit 7 already high
    int steps = 0;
    while (s != State::kOperationEnabled && steps < 10) {
      const std::uint16_t cw = next_controlword(s, State::kOperationEnabled, last);
      s = apply(s, cw, last);
      last = cw;
      ++steps;
    }
    EXPECT_EQ(s, State::kOperationEnabled) << "from " << state_name(start);
    EXPECT_LE(steps, 6) << "from " << state_name(start);
  }
  // The standard enable sequence.
  EXPECT_EQ(next_controlword(State::kSwitchOnDisabled, State::kOperationEnabled, 0), cw::kShutdown);
  EXPECT_EQ(next_controlword(State::kReadyToSwitchOn, State::kOperationEnabled, 0x06), cw::kSwitchOn);
  EXPECT_EQ(next_controlword(State::kSwitchedOn, State::kOperationEnabled, 0x07), cw::kEnableOperation);
  // Fault reset is an edge: 0x00 first, then 0x80.
  EXPECT_EQ(next_controlword(State::kFault, State::kOperationEnabled, 0x0F), cw::kDisableVoltage);
  EXPECT_EQ(next_controlword(State::kFault, State::kOperationEnabled, 0x00), cw::kFaultReset);
  EXPECT_EQ(next_controlword(State::kOperationEnabled, State::kSwitchOnDisabled, 0x0F), cw::kDisableVoltage);
}

}  // namespace
}  // namespace cairn::canopen

#include "drivers/canopen/diff_drive.hpp"

namespace cairn::canopen {
namespace {

TEST(DiffDrive, CommandsAndOdometryRoundTrip) {
  DiffDriveGeometry g;
  g.wheel_radius_m = 0.1;
  g.track_m = 0.5;
  g.gear_ratio = 20;
  g.encoder_counts_per_rev = 4096;
  // 0.5 m/s straight: 0.5 / 0.1 = 5 rad/s at the wheel = 100 rad/s at the motor.
  WheelCommand c = wheel_command(g, 0.5, 0.0);
  EXPECT_NEAR(c.left, 5.0 * 4096 * 20 / (2 * std::numbers::pi), 1);
  EXPECT_EQ(c.right, -c.left);  // mirrored motor
  // Turning on the spot: wheels opposite, same magnitude.
  c = wheel_command(g, 0.0, 1.0);
  EXPECT_EQ(c.left, c.right);   // left backwards, right forwards (inverted sign)
  EXPECT_LT(c.left, 0);
  // Odometry inverts it, including across the 32-bit encoder wrap.
  const std::int32_t prev = 2147483000;
  const std::int32_t now = static_cast<std::int32_t>(static_cast<std::uint32_t>(prev) + 1304u);  // wraps
  const WheelOdometry o = wheel_odometry(g, now, -now, prev, -prev, 1304, -1304);
  const double m = 1304 * 0.1 / (4096 * 20 / (2 * std::numbers::pi));
  EXPECT_NEAR(o.left_m, m, 1e-12);
  EXPECT_NEAR(o.right_m, m, 1e-12);
  EXPECT_NEAR(o.left_speed, m, 1e-12);
}

}  // namespace
}  // namespace cairn::canopen
