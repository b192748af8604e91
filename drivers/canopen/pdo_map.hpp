// The drive's process data as Cairn uses it, in one table (pdo_map::kDrive): the objects
// each PDO carries (index, sub, bits, signedness) and its transmission type. From it come
// the master's SDO remapping sequence (remap_write), its RPDO packing and TPDO unpacking
// (pdo_fields, slot), and the emulated drive's default mapping objects. Constexpr, no heap.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>

#include "drivers/canopen/canopen_codec.hpp"
#include "drivers/canopen/object_dictionary.hpp"

namespace cairn::canopen {

/// One object mapped into a PDO.
struct MappedObject {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t bits = 0;  // 8, 16, 32
  bool is_signed = false;

  constexpr PdoField field() const { return {bits, is_signed}; }
  /// As written to the mapping object (0x1600+k / 0x1A00+k).
  constexpr std::uint32_t entry() const { return mapping_entry(index, sub, bits); }
};

enum class PdoDirection : std::uint8_t { kRpdo, kTpdo };  // RPDO: master -> drive; TPDO: drive -> master

inline constexpr std::size_t kMaxMappedObjects = 8;  // 8 bytes of 8-bit objects

struct PdoMapping {
  PdoDirection direction = PdoDirection::kRpdo;
  std::uint8_t pdo = 0;  // 0-based: 0 = RPDO1 / TPDO1
  std::uint8_t transmission_type = od::kTransmissionEverySync;
  std::uint8_t count = 0;
  std::array<MappedObject, kMaxMappedObjects> objects{};

  // consteval: a table that does not fit a PDO does not compile.
  consteval PdoMapping(PdoDirection d, std::uint8_t k, std::initializer_list<MappedObject> mapped,
                       std::uint8_t transmission = od::kTransmissionEverySync)
      : direction(d), pdo(k), transmission_type(transmission) {
    std::size_t bits = 0;
    for (const MappedObject& o : mapped) {
      if (count == kMaxMappedObjects || o.bits == 0 || o.bits % 8 || (bits += o.bits) > 64) throw "does not fit a PDO";
      objects[count++] = o;
    }
    if (k >= 4) throw "not a predefined PDO";
  }
  constexpr std::span<const MappedObject> mapped() const { return {objects.data(), count}; }
};

constexpr std::uint16_t communication_index(const PdoMapping& m) {
  return m.direction == PdoDirection::kRpdo ? od::rpdo_communication(m.pdo) : od::tpdo_communication(m.pdo);
}
constexpr std::uint16_t mapping_index(const PdoMapping& m) {
  return m.direction == PdoDirection::kRpdo ? od::rpdo_mapping(m.pdo) : od::tpdo_mapping(m.pdo);
}
/// The predefined COB-ID of this PDO for `node` (0x200 + node for RPDO1, 0x180 + node for TPDO1, ...).
constexpr std::uint32_t cob_id(const PdoMapping& m, std::uint8_t node) {
  return (m.direction == PdoDirection::kRpdo ? kCobRpdo[m.pdo] : kCobTpdo[m.pdo]) + node;
}
/// Where an object sits in the PDO (the position of its value for pack_pdo / unpack_pdo);
/// kMaxMappedObjects if it is not mapped.
constexpr std::size_t slot(const PdoMapping& m, std::uint16_t index, std::uint8_t sub = 0) {
  for (std::size_t i = 0; i < m.count; ++i) {
    if (m.objects[i].index == index && m.objects[i].sub == sub) return i;
  }
  return kMaxMappedObjects;
}

/// The mapping's fields, contiguous, for pack_pdo / unpack_pdo.
struct PdoFields {
  std::array<PdoField, kMaxMappedObjects> fields{};
  std::size_t count = 0;
  constexpr std::span<const PdoField> span() const { return {fields.data(), count}; }
};
constexpr PdoFields pdo_fields(const PdoMapping& m) {
  PdoFields f;
  for (const MappedObject& o : m.mapped()) f.fields[f.count++] = o.field();
  return f;
}

/// An object and the value it is given over SDO (expedited: size 1..4 bytes).
struct SdoWrite {
  SdoAddress address;
  std::uint32_t value = 0;
  std::uint8_t size = 0;
};
// The objects a mapping defines, as they read once it is in place.
constexpr SdoWrite pdo_cob_id_object(const PdoMapping& m, std::uint8_t node) {
  return {{communication_index(m), od::kPdoCobId}, cob_id(m, node), 4};
}
constexpr SdoWrite pdo_transmission_type_object(const PdoMapping& m) {
  return {{communication_index(m), od::kPdoTransmissionType}, m.transmission_type, 1};
}
constexpr SdoWrite pdo_mapping_count_object(const PdoMapping& m) { return {{mapping_index(m), od::kPdoMappingCount}, m.count, 1}; }
constexpr SdoWrite pdo_mapping_entry_object(const PdoMapping& m, std::size_t i) {
  return {{mapping_index(m), static_cast<std::uint8_t>(i + 1)}, m.objects[i].entry(), 4};
}

/// The standard remapping procedure, as SDO writes 0 .. remap_writes(m) - 1: disable the
/// PDO (COB-ID bit 31), clear the count, write each entry, write the count, the
/// transmission type, then the COB-ID without bit 31 (enabled).
constexpr std::size_t remap_writes(const PdoMapping& m) { return 5 + m.count; }
constexpr SdoWrite remap_write(const PdoMapping& m, std::uint8_t node, std::size_t i) {
  if (i == 0) {
    SdoWrite w = pdo_cob_id_object(m, node);
    w.value |= od::kPdoDisabled;
    return w;
  }
  if (i == 1) {
    SdoWrite w = pdo_mapping_count_object(m);
    w.value = 0;
    return w;
  }
  if (i < 2u + m.count) return pdo_mapping_entry_object(m, i - 2);
  if (i == 2u + m.count) return pdo_mapping_count_object(m);
  if (i == 3u + m.count) return pdo_transmission_type_object(m);
  return pdo_cob_id_object(m, node);
}

namespace pdo_map {
/// RPDO1: controlword, target velocity.
inline constexpr PdoMapping kRpdo1{PdoDirection::kRpdo, 0, {{od::kControlword, 0, 16, false}, {od::kTargetVelocity, 0, 32, true}}};
/// TPDO1: statusword, velocity actual.
inline constexpr PdoMapping kTpdo1{PdoDirection::kTpdo, 0, {{od::kStatusword, 0, 16, false}, {od::kVelocityActual, 0, 32, true}}};
/// TPDO2: position actual.
inline constexpr PdoMapping kTpdo2{PdoDirection::kTpdo, 1, {{od::kPositionActual, 0, 32, true}}};
/// Every PDO of a drive, in the order the master configures them.
inline constexpr std::array<PdoMapping, 3> kDrive = {kRpdo1, kTpdo1, kTpdo2};
}  // namespace pdo_map

}  // namespace cairn::canopen
