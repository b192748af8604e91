// Which Cyclone DDS configuration a Cairn program runs with.
//
//   loopback  (default) interface lo, no multicast, peer 127.0.0.1 — config/dds/loopback.xml
//   lan       explicit interface and unicast peers from the program's [dds] section
//   secure    lan with DDS Security: the fleet member's keys from [dds] keys (docs/security.md)
//   secure-loopback  loopback with DDS Security (the tests' secure fleet)
//   env       whatever CYCLONEDDS_URI says (explicitly requested only)
//   PATH.xml  a Cyclone configuration file
//
// When the [dds] section is absent the profile is "loopback" unless
// CYCLONEDDS_URI is set, in which case that is used (and logged).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cairn {
class ConfigSection;
}

namespace cairn::dds {

struct DdsProfile {
  std::string name;         // "loopback", "lan", "env" or the file path
  std::string xml;          // configuration text passed to dds_create_domain ("" = use CYCLONEDDS_URI)
  std::string description;  // one line for the start-up log: interface, multicast, peers
  std::uint32_t domain = 0;
  bool loopback_only = false;
};

/// The built-in loopback profile (the text of config/dds/loopback.xml).
const std::string& loopback_xml();
DdsProfile loopback_profile(std::uint32_t domain = 0);
/// One named interface (never autodetected) and unicast peers: IPv4 or IPv6 addresses
/// (unicast; IPv6 optionally in brackets) or host names, no ports, each once. Throws
/// std::invalid_argument saying what is wrong with them.
DdsProfile lan_profile(const std::string& interface_name, const std::vector<std::string>& peers,
                       std::uint32_t domain = 0);
/// Why a [dds] interface or peer would be refused ("" if it is fine).
std::string lan_interface_problem(const std::string& name);
std::string lan_peer_problem(const std::string& peer);

/// DDS Security for one member of the fleet (scripts/fleet-keys.sh): `member_dir` holds
/// cert.pem, key.pem, ca.pem, governance.p7s, permissions.p7s and crl.pem. PKI-DH
/// authentication, access control by the signed permissions, AES-GCM for what the
/// governance protects (every topic). Throws std::invalid_argument naming what is missing.
std::string security_xml(const std::string& member_dir);
/// `base` (loopback or lan) with security_xml(member_dir) in its domain.
DdsProfile secured(const DdsProfile& base, const std::string& member_dir);

/// Reads the optional [dds] section: profile, domain, interface, peers, keys.
DdsProfile profile_from_config(const std::optional<ConfigSection>& dds_section);

}  // namespace cairn::dds
