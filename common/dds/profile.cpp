#include "common/dds/profile.hpp"

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/config.hpp"
#include "common/dds/loopback_xml.hpp"

namespace cairn::dds {

const std::string& loopback_xml() {
  static const std::string xml(kLoopbackXml);
  return xml;
}

DdsProfile loopback_profile(std::uint32_t domain) {
  return {"loopback", loopback_xml(),
          "interface lo, multicast off, unicast peer 127.0.0.1, participant index auto (max 60)", domain, true};
}

DdsProfile lan_profile(const std::string& interface_name, const std::vector<std::string>& peers, std::uint32_t domain) {
  std::ostringstream xml, desc;
  xml << "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"" << interface_name
      << "\"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
      << "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex><Peers>";
  desc << "interface " << interface_name << ", multicast off, unicast peers";
  for (const auto& p : peers) {
    xml << "<Peer address=\"" << p << "\"/>";
    desc << " " << p;
  }
  xml << "</Peers></Discovery></Domain></CycloneDDS>";
  return {"lan", xml.str(), desc.str(), domain, interface_name == "lo"};
}

DdsProfile profile_from_config(const std::optional<ConfigSection>& s) {
  const char* env = std::getenv("CYCLONEDDS_URI");
  if (!s) {
    if (env && *env) return {"env", "", std::string("CYCLONEDDS_URI=") + env, 0, false};
    return loopback_profile();
  }
  const auto domain = static_cast<std::uint32_t>(s->integer_or("domain", 0, {0, 230}));
  const std::string name = s->string_or("profile", "loopback");
  if (name == "loopback") return loopback_profile(domain);
  if (name == "env") {
    if (!env || !*env) s->fail("profile", "profile \"env\" needs CYCLONEDDS_URI to be set");
    return {"env", "", std::string("CYCLONEDDS_URI=") + env, domain, false};
  }
  if (name == "lan") {
    const std::string iface = s->string("interface");
    const auto peers = s->strings("peers");
    if (peers.empty()) s->fail("peers", "profile \"lan\" needs at least one peer address");
    return lan_profile(iface, peers, domain);
  }
  if (name.size() > 4 && name.substr(name.size() - 4) == ".xml") {
    std::ifstream in(name);
    if (!in) s->fail("profile", "cannot read the DDS profile file " + name);
    return {name, "file://" + name, "configuration file " + name, domain, false};
  }
  s->fail("profile", "expected \"loopback\", \"lan\", \"env\" or a path ending in .xml, got \"" + name + "\"");
}

}  // namespace cairn::dds
