#include "common/dds/participant.hpp"

#include <map>
#include <mutex>

#include "common/dds/error.hpp"

namespace cairn::dds {

namespace {
std::mutex g_domains_mutex;
std::map<std::uint32_t, std::string> g_domains;  // domain id -> profile name it was created with
}  // namespace

Participant::Participant(const DdsProfile& profile) : profile_(profile) {
  if (!profile.xml.empty()) {
    std::lock_guard lock(g_domains_mutex);
    auto it = g_domains.find(profile.domain);
    if (it == g_domains.end()) {
      const dds_entity_t d = dds_create_domain(profile.domain, profile.xml.c_str());
      if (d < 0 && d != DDS_RETCODE_PRECONDITION_NOT_MET) {
        check(d, "dds_create_domain(" + std::to_string(profile.domain) + ", profile " + profile.name + ")");
      }
      g_domains[profile.domain] = profile.name;
    } else if (it->second != profile.name) {
      throw DdsError("Participant: domain " + std::to_string(profile.domain) + " already runs profile " + it->second +
                         ", cannot also use " + profile.name,
                     DDS_RETCODE_PRECONDITION_NOT_MET);
    }
  }
  const dds_entity_t pp = dds_create_participant(profile.domain, nullptr, nullptr);
  check(pp, "dds_create_participant(domain " + std::to_string(profile.domain) + ", profile " + profile.name + ")");
  pp_ = Entity(pp);
}

std::string Participant::describe() const {
  return "profile " + profile_.name + " (" + profile_.description + "), domain " + std::to_string(profile_.domain);
}

}  // namespace cairn::dds
