#include "common/dds/participant.hpp"

#include <map>
#include <mutex>

#include "common/dds/error.hpp"

namespace cairn::dds {

namespace {
struct Domain {
  std::string profile;     // the profile it was created with
  dds_entity_t handle = 0;  // 0: created elsewhere (not ours to delete)
  int users = 0;           // live Participants on it
};
std::mutex g_domains_mutex;
std::map<std::uint32_t, Domain> g_domains;  // domain id -> the domain this class created

// Drops one user of the domain; the last deletes it.
void release(std::uint32_t id) {
  std::lock_guard lock(g_domains_mutex);
  const auto it = g_domains.find(id);
  if (it == g_domains.end() || --it->second.users > 0) return;
  if (it->second.handle > 0) dds_delete(it->second.handle);
  g_domains.erase(it);
}
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
      it = g_domains.emplace(profile.domain, Domain{profile.name, d > 0 ? d : 0, 0}).first;
    } else if (it->second.profile != profile.name) {
      throw DdsError("Participant: domain " + std::to_string(profile.domain) + " already runs profile " +
                         it->second.profile + ", cannot also use " + profile.name,
                     DDS_RETCODE_PRECONDITION_NOT_MET);
    }
    ++it->second.users;
  }
  const dds_entity_t pp = dds_create_participant(profile.domain, nullptr, nullptr);
  if (pp < 0 && !profile.xml.empty()) release(profile.domain);
  check(pp, "dds_create_participant(domain " + std::to_string(profile.domain) + ", profile " + profile.name + ")");
  pp_ = Entity(pp);
}

Participant::~Participant() {
  pp_.reset();
  if (!profile_.xml.empty()) release(profile_.domain);
}

std::string Participant::describe() const {
  return "profile " + profile_.name + " (" + profile_.description + "), domain " + std::to_string(profile_.domain);
}

}  // namespace cairn::dds
