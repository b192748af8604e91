#include "common/config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cairn {

namespace {

std::string type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}

template <typename T>
std::string range_text(const char* what, Range<T> r) {
  std::ostringstream s;
  s << what;
  const bool has_min = r.min != std::numeric_limits<T>::lowest();
  const bool has_max = r.max != std::numeric_limits<T>::max();
  if (has_min && has_max) {
    s << " in [" << r.min << ", " << r.max << "]";
  } else if (has_min) {
    s << " >= " << r.min;
  } else if (has_max) {
    s << " <= " << r.max;
  }
  return s.str();
}

void collect_paths(const toml::table& t, const std::string& prefix, std::vector<std::pair<std::string, const toml::node*>>* out) {
  for (const auto& [k, v] : t) {
    std::string path = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    out->emplace_back(path, &v);
    if (const auto* sub = v.as_table()) collect_paths(*sub, path, out);
    if (const auto* arr = v.as_array()) {
      if (arr->is_array_of_tables()) {
        for (std::size_t i = 0; i < arr->size(); ++i) {
          collect_paths(*arr->get(i)->as_table(), path + "[" + std::to_string(i) + "]", out);
        }
      }
    }
  }
}

}  // namespace

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// ---------------------------------------------------------------- ConfigDocument

ConfigDocument::ConfigDocument(ConfigDocument&&) noexcept = default;
ConfigDocument& ConfigDocument::operator=(ConfigDocument&&) noexcept = default;
ConfigDocument::~ConfigDocument() = default;

ConfigDocument ConfigDocument::load(const std::string& path) {
  ConfigDocument doc;
  doc.name_ = path;
  try {
    doc.table_ = std::make_unique<toml::table>(toml::parse_file(path));
  } catch (const toml::parse_error& e) {
    const auto& src = e.source();
    std::ostringstream s;
    if (src.begin.line == 0) {
      s << path << ": cannot read the configuration file: " << e.description();
    } else {
      s << path << ":" << src.begin.line << ":" << src.begin.column << ": TOML syntax error: " << e.description();
    }
    throw ConfigError(s.str());
  }
  return doc;
}

ConfigDocument ConfigDocument::parse(std::string_view text, const std::string& name) {
  ConfigDocument doc;
  doc.name_ = name;
  try {
    doc.table_ = std::make_unique<toml::table>(toml::parse(text, std::string_view(name)));
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << name << ":" << e.source().begin.line << ":" << e.source().begin.column
      << ": TOML syntax error: " << e.description();
    throw ConfigError(s.str());
  }
  return doc;
}

ConfigSection ConfigDocument::root() const { return ConfigSection(this, table_.get(), ""); }

std::string ConfigDocument::where(const toml::node* node) const {
  std::ostringstream s;
  s << name_;
  if (node && node->source().begin.line > 0) s << ":" << node->source().begin.line << ":" << node->source().begin.column;
  return s.str();
}

void ConfigDocument::finish() const {
  std::vector<std::pair<std::string, const toml::node*>> all;
  collect_paths(*table_, "", &all);
  std::ostringstream errors;
  int count = 0;
  for (const auto& entry : all) {
    const std::string& path = entry.first;  // (named, not bound: lambdas below capture it)
    const toml::node* node = entry.second;
    if (used_->count(path)) continue;
    // A table whose keys were all read counts as used (it has no value of its own).
    if (node->is_table() || (node->is_array() && node->as_array()->is_array_of_tables())) {
      const bool any_child_used = std::any_of(used_->begin(), used_->end(), [&](const std::string& u) {
        return u.size() > path.size() && u.compare(0, path.size(), path) == 0 && (u[path.size()] == '.' || u[path.size()] == '[');
      });
      if (any_child_used) continue;
    }
    // Skip children of an unknown table: the table itself is reported.
    bool parent_unknown = false;
    for (const auto& other_entry : all) {
      const std::string& other = other_entry.first;
      if (other.size() < path.size() && path.compare(0, other.size(), other) == 0 &&
          (path[other.size()] == '.' || path[other.size()] == '[') && !used_->count(other)) {
        const bool other_has_used_child = std::any_of(used_->begin(), used_->end(), [&](const std::string& u) {
          return u.size() > other.size() && u.compare(0, other.size(), other) == 0;
        });
        if (!other_has_used_child) parent_unknown = true;
      }
    }
    if (parent_unknown) continue;
    std::string hint;
    std::size_t best = 3;
    for (const auto& u : *used_) {
      const std::size_t d = edit_distance(u, path);
      if (d < best) {
        best = d;
        hint = u;
      }
    }
    errors << (count ? "\n" : "") << where(node) << ": " << path << ": unknown key";
    if (!hint.empty()) errors << " (did you mean '" << hint << "'?)";
    ++count;
  }
  if (count) throw ConfigError(errors.str());
}

// ---------------------------------------------------------------- ConfigSection

std::string ConfigSection::path_of(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

void ConfigSection::fail(std::string_view key, const std::string& message) const {
  throw ConfigError(doc_->where(lookup(key) ? lookup(key) : table_) + ": " + path_of(key) + ": " + message);
}

// Every key the schema asks about is known, present or not: finish() reports only the others.
const toml::node* ConfigSection::lookup(std::string_view key) const {
  doc_->mark_used(path_of(key));
  return table_->get(key);
}

bool ConfigSection::has(std::string_view key) const { return lookup(key) != nullptr; }

const toml::node& ConfigSection::require(std::string_view key, const char* expected) const {
  const toml::node* n = lookup(key);
  if (!n) {
    std::string where = doc_->name();
    if (!path_.empty() && table_->source().begin.line > 0) where = doc_->where(table_);
    throw ConfigError(where + ": " + path_of(key) + ": missing required key (expected " + expected + ")");
  }
  doc_->mark_used(path_of(key));
  return *n;
}

std::int64_t ConfigSection::integer(std::string_view key, Range<std::int64_t> range) const {
  const std::string expected = range_text("an integer", range);
  const toml::node& n = require(key, expected.c_str());
  const auto v = n.value_exact<std::int64_t>();
  if (!v) fail(key, "expected " + expected + ", got " + type_name(n));
  if (*v < range.min || *v > range.max) fail(key, "expected " + expected + ", got " + std::to_string(*v));
  return *v;
}

std::int64_t ConfigSection::integer_or(std::string_view key, std::int64_t fallback, Range<std::int64_t> range) const {
  return has(key) ? integer(key, range) : fallback;
}

double ConfigSection::number(std::string_view key, Range<double> range) const {
  const std::string expected = range_text("a number", range);
  const toml::node& n = require(key, expected.c_str());
  std::optional<double> v;
  if (n.is_floating_point()) v = n.as_floating_point()->get();
  if (n.is_integer()) v = static_cast<double>(n.as_integer()->get());
  if (!v) fail(key, "expected " + expected + ", got " + type_name(n));
  if (!std::isfinite(*v) || *v < range.min || *v > range.max) {
    std::ostringstream s;
    s << "expected " << expected << ", got " << *v;
    fail(key, s.str());
  }
  return *v;
}

double ConfigSection::number_or(std::string_view key, double fallback, Range<double> range) const {
  return has(key) ? number(key, range) : fallback;
}

bool ConfigSection::boolean(std::string_view key) const {
  const toml::node& n = require(key, "true or false");
  if (!n.is_boolean()) fail(key, "expected true or false, got " + type_name(n));
  return n.as_boolean()->get();
}

bool ConfigSection::boolean_or(std::string_view key, bool fallback) const { return has(key) ? boolean(key) : fallback; }

std::string ConfigSection::string(std::string_view key) const {
  const toml::node& n = require(key, "a string");
  if (!n.is_string()) fail(key, "expected a string, got " + type_name(n));
  return n.as_string()->get();
}

std::string ConfigSection::string_or(std::string_view key, std::string_view fallback) const {
  return has(key) ? string(key) : std::string(fallback);
}

std::string ConfigSection::choice(std::string_view key, const std::vector<std::string>& choices) const {
  std::string expected = "one of";
  for (std::size_t i = 0; i < choices.size(); ++i) expected += (i ? ", \"" : " \"") + choices[i] + "\"";
  const toml::node& n = require(key, expected.c_str());
  if (!n.is_string()) fail(key, "expected " + expected + ", got " + type_name(n));
  const std::string v = n.as_string()->get();
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    fail(key, "expected " + expected + ", got \"" + v + "\"");
  }
  return v;
}

std::string ConfigSection::choice_or(std::string_view key, std::string_view fallback,
                                     const std::vector<std::string>& choices) const {
  return has(key) ? choice(key, choices) : std::string(fallback);
}

std::vector<double> ConfigSection::numbers(std::string_view key, std::size_t min_count, std::size_t max_count) const {
  const std::string expected = "an array of " + std::to_string(min_count) +
                               (max_count == min_count ? "" : (max_count == std::numeric_limits<std::size_t>::max()
                                                                   ? " or more"
                                                                   : " to " + std::to_string(max_count))) +
                               " numbers";
  const toml::node& n = require(key, expected.c_str());
  const toml::array* arr = n.as_array();
  if (!arr) fail(key, "expected " + expected + ", got " + type_name(n));
  if (arr->size() < min_count || arr->size() > max_count) {
    fail(key, "expected " + expected + ", got " + std::to_string(arr->size()) + " elements");
  }
  std::vector<double> out;
  for (const auto& e : *arr) {
    if (e.is_floating_point()) {
      out.push_back(e.as_floating_point()->get());
    } else if (e.is_integer()) {
      out.push_back(static_cast<double>(e.as_integer()->get()));
    } else {
      fail(key, "expected " + expected + ", found " + type_name(e) + " in it");
    }
    if (!std::isfinite(out.back())) fail(key, "expected finite numbers");
  }
  return out;
}

std::vector<std::string> ConfigSection::strings(std::string_view key) const {
  const toml::node& n = require(key, "an array of strings");
  const toml::array* arr = n.as_array();
  if (!arr) fail(key, "expected an array of strings, got " + type_name(n));
  std::vector<std::string> out;
  for (const auto& e : *arr) {
    if (!e.is_string()) fail(key, "expected an array of strings, found " + type_name(e) + " in it");
    out.push_back(e.as_string()->get());
  }
  return out;
}

ConfigSection ConfigSection::section(std::string_view key) const {
  const toml::node& n = require(key, "a table");
  if (!n.is_table()) fail(key, "expected a table ([" + path_of(key) + "]), got " + type_name(n));
  return ConfigSection(doc_, n.as_table(), path_of(key));
}

std::optional<ConfigSection> ConfigSection::optional_section(std::string_view key) const {
  if (!has(key)) return std::nullopt;
  return section(key);
}

std::vector<ConfigSection> ConfigSection::sections(std::string_view key) const {
  const toml::node& n = require(key, "an array of tables");
  const toml::array* arr = n.as_array();
  if (!arr || !arr->is_array_of_tables()) fail(key, "expected an array of tables ([[" + path_of(key) + "]]), got " + type_name(n));
  std::vector<ConfigSection> out;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    out.push_back(ConfigSection(doc_, arr->get(i)->as_table(), path_of(key) + "[" + std::to_string(i) + "]"));
  }
  return out;
}

}  // namespace cairn
