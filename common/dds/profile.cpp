#include "common/dds/profile.hpp"

#include <arpa/inet.h>
#include <dds/dds.h>
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

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

std::string lan_interface_problem(const std::string& name) {
  if (name.empty()) return "an interface name is needed (e.g. \"eth0\"): the lan profile never autodetects one";
  if (name.size() > 15) return "\"" + name + "\" is longer than an interface name can be (15 characters)";
  if (name == "." || name == "..") return "\"" + name + "\" is not an interface name";
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.')
      return "\"" + name + "\": an interface name here is letters, digits, '-', '_' and '.'";
  return "";
}

std::string lan_peer_problem(const std::string& peer) {
  if (peer.empty()) return "an empty peer address";
  // A literal address: unicast only (the profile turns multicast off; a multicast or
  // unspecified peer would be silently useless).
  std::string literal = peer;
  if (literal.size() > 2 && literal.front() == '[' && literal.back() == ']') literal = literal.substr(1, literal.size() - 2);
  in_addr v4{};
  in6_addr v6{};
  if (literal == peer && inet_pton(AF_INET, literal.c_str(), &v4) == 1) {
    const std::uint32_t a = ntohl(v4.s_addr);
    if ((a >> 28) == 0xE) return peer + " is a multicast address: peers are unicast";
    if (a == 0 || a == 0xFFFFFFFFu) return peer + " is not a host's address";
    return "";
  }
  if (inet_pton(AF_INET6, literal.c_str(), &v6) == 1) {
    if (v6.s6_addr[0] == 0xFF) return peer + " is a multicast address: peers are unicast";
    if (IN6_IS_ADDR_UNSPECIFIED(&v6)) return peer + " is not a host's address";
    return "";
  }
  if (literal != peer) return peer + ": not an IPv6 address";
  // A host name (RFC 1123): labels of letters, digits and '-', separated by dots. No port:
  // Cyclone derives the ports from the domain and the participant index.
  if (peer.size() > 253) return "peer name too long: " + peer;
  std::size_t label = 0;
  for (std::size_t i = 0; i < peer.size(); ++i) {
    const char c = peer[i];
    if (c == '.') {
      if (label == 0) return "\"" + peer + "\" is neither an address nor a host name";
      label = 0;
      continue;
    }
    if (c == ':') return "\"" + peer + "\": a peer is an address or a host name, without a port (Cyclone derives the ports)";
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-')
      return "\"" + peer + "\" is neither an address nor a host name";
    if (++label > 63) return "\"" + peer + "\": a label of a host name is at most 63 characters";
  }
  if (label == 0) return "\"" + peer + "\" is neither an address nor a host name";
  return "";
}

DdsProfile lan_profile(const std::string& interface_name, const std::vector<std::string>& peers, std::uint32_t domain) {
  if (const std::string why = lan_interface_problem(interface_name); !why.empty()) throw std::invalid_argument(why);
  if (peers.empty()) throw std::invalid_argument("at least one unicast peer address is needed (multicast is off)");
  for (std::size_t i = 0; i < peers.size(); ++i) {
    if (const std::string why = lan_peer_problem(peers[i]); !why.empty()) throw std::invalid_argument(why);
    if (std::find(peers.begin(), peers.begin() + static_cast<std::ptrdiff_t>(i), peers[i]) != peers.begin() + static_cast<std::ptrdiff_t>(i))
      throw std::invalid_argument(peers[i] + " is listed twice");
  }
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

namespace {

// Debian installs the security plugins beside libddsc, in libddsc0debian/; elsewhere they
// are on the library path under their plain names.
std::string plugin(const char* name) {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&dds_create_participant), &info) != 0 && info.dli_fname) {
    std::string dir(info.dli_fname);
    dir.erase(dir.find_last_of('/') + 1);
    const std::string path = dir + "libddsc0debian/lib" + name + ".so";
    if (access(path.c_str(), R_OK) == 0) return path;
  }
  return name;
}

std::string xml_escaped(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

std::string security_xml(const std::string& member_dir) {
  if (member_dir.empty()) throw std::invalid_argument("DDS security: no keys directory given");
  // Cyclone expands ${VAR} in its configuration's values: a '$' would change the path.
  for (char c : member_dir)
    if (c == '$' || static_cast<unsigned char>(c) < 0x20)
      throw std::invalid_argument("DDS security: the keys directory's path may not hold '$' or control characters: " +
                                  member_dir);
  const std::string dir = member_dir.back() == '/' ? member_dir : member_dir + "/";
  std::string missing;
  for (const char* f : {"cert.pem", "key.pem", "ca.pem", "governance.p7s", "permissions.p7s", "crl.pem"})
    if (access((dir + f).c_str(), R_OK) != 0) missing += std::string(missing.empty() ? "" : ", ") + f;
  if (!missing.empty())
    throw std::invalid_argument("DDS security: the keys directory " + member_dir + " lacks (or cannot read) " + missing +
                                "; scripts/fleet-keys.sh add makes one (docs/security.md)");
  const std::string f = "file:" + xml_escaped(dir);
  std::ostringstream x;
  x << "<Security><Authentication><Library path=\"" << xml_escaped(plugin("dds_security_auth"))
    << "\" initFunction=\"init_authentication\" finalizeFunction=\"finalize_authentication\"/>"
    << "<IdentityCertificate>" << f << "cert.pem</IdentityCertificate><IdentityCA>" << f << "ca.pem</IdentityCA>"
    << "<PrivateKey>" << f << "key.pem</PrivateKey><CRL>" << f << "crl.pem</CRL></Authentication>"
    << "<AccessControl><Library path=\"" << xml_escaped(plugin("dds_security_ac"))
    << "\" initFunction=\"init_access_control\" finalizeFunction=\"finalize_access_control\"/>"
    << "<PermissionsCA>" << f << "ca.pem</PermissionsCA><Governance>" << f << "governance.p7s</Governance>"
    << "<Permissions>" << f << "permissions.p7s</Permissions></AccessControl>"
    << "<Cryptographic><Library path=\"" << xml_escaped(plugin("dds_security_crypto"))
    << "\" initFunction=\"init_crypto\" finalizeFunction=\"finalize_crypto\"/></Cryptographic></Security>";
  return x.str();
}

DdsProfile secured(const DdsProfile& base, const std::string& member_dir) {
  const std::string security = security_xml(member_dir);
  DdsProfile p = base;
  const std::size_t at = p.xml.rfind("</Domain>");
  if (at == std::string::npos) throw std::invalid_argument("DDS security: profile " + base.name + " has no <Domain> to secure");
  p.xml.insert(at, security);
  p.name = base.name == "loopback" ? "secure-loopback" : "secure";
  p.description = base.description + "; DDS Security (PKI-DH, access control, AES-GCM) with the keys in " + member_dir;
  return p;
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
  if (name == "lan" || name == "secure") {
    const std::string iface = s->string("interface");
    if (const std::string why = lan_interface_problem(iface); !why.empty()) s->fail("interface", why);
    const auto peers = s->strings("peers");
    if (peers.empty()) s->fail("peers", "profile \"" + name + "\" needs at least one peer address");
    DdsProfile lan;
    try {
      lan = lan_profile(iface, peers, domain);
    } catch (const std::invalid_argument& e) {
      s->fail("peers", e.what());
    }
    if (name == "lan") return lan;
    try {
      return secured(lan, s->string("keys"));
    } catch (const std::invalid_argument& e) {
      s->fail("keys", e.what());
    }
  }
  if (name == "secure-loopback") {
    try {
      return secured(loopback_profile(domain), s->string("keys"));
    } catch (const std::invalid_argument& e) {
      s->fail("keys", e.what());
    }
  }
  if (name.size() > 4 && name.substr(name.size() - 4) == ".xml") {
    std::ifstream in(name);
    if (!in) s->fail("profile", "cannot read the DDS profile file " + name);
    return {name, "file://" + name, "configuration file " + name, domain, false};
  }
  s->fail("profile", "expected \"loopback\", \"lan\", \"secure\", \"secure-loopback\", \"env\" or a path ending in .xml, got \"" +
                         name + "\"");
}

}  // namespace cairn::dds
