// Strict configuration: TOML files (parsed by toml++) read through a schema
// written in code. A missing required key, a misspelled or unknown key, a
// wrong type or an out-of-range value is an error that names the file, the
// line, the key and the expected form. Optional keys have documented defaults;
// an unknown key never silently falls back to one.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace toml {
inline namespace v3 {
class table;
class node;
}  // namespace v3
}  // namespace toml

namespace cairn {

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

template <typename T>
struct Range {
  T min = std::numeric_limits<T>::lowest();
  T max = std::numeric_limits<T>::max();
};

class ConfigDocument;

/// A table inside a configuration document (the root, or a [section]).
class ConfigSection {
 public:
  std::int64_t integer(std::string_view key, Range<std::int64_t> range = {}) const;
  std::int64_t integer_or(std::string_view key, std::int64_t fallback, Range<std::int64_t> range = {}) const;
  double number(std::string_view key, Range<double> range = {}) const;
  double number_or(std::string_view key, double fallback, Range<double> range = {}) const;
  bool boolean(std::string_view key) const;
  bool boolean_or(std::string_view key, bool fallback) const;
  std::string string(std::string_view key) const;
  std::string string_or(std::string_view key, std::string_view fallback) const;
  /// A string that must be one of `choices`.
  std::string choice(std::string_view key, const std::vector<std::string>& choices) const;
  std::string choice_or(std::string_view key, std::string_view fallback, const std::vector<std::string>& choices) const;
  std::vector<double> numbers(std::string_view key, std::size_t min_count = 0,
                              std::size_t max_count = std::numeric_limits<std::size_t>::max()) const;
  std::vector<std::string> strings(std::string_view key) const;

  bool has(std::string_view key) const;
  /// A required sub-table.
  ConfigSection section(std::string_view key) const;
  /// An optional sub-table.
  std::optional<ConfigSection> optional_section(std::string_view key) const;
  /// An array of tables ([[key]]).
  std::vector<ConfigSection> sections(std::string_view key) const;

  /// "robot.id" for key "id" in section "robot".
  std::string path_of(std::string_view key) const;
  /// Throws a ConfigError about `key` with the file and line.
  [[noreturn]] void fail(std::string_view key, const std::string& message) const;

 private:
  friend class ConfigDocument;
  ConfigSection(const ConfigDocument* doc, const toml::table* table, std::string path)
      : doc_(doc), table_(table), path_(std::move(path)) {}
  const toml::node* lookup(std::string_view key) const;
  const toml::node& require(std::string_view key, const char* expected) const;

  const ConfigDocument* doc_;
  const toml::table* table_;
  std::string path_;
};

/// A parsed configuration file; remembers which keys the schema read.
class ConfigDocument {
 public:
  /// Parses a file. Throws ConfigError naming the file on a missing file or a TOML syntax error.
  static ConfigDocument load(const std::string& path);
  /// Parses TOML text; `name` is used in messages.
  static ConfigDocument parse(std::string_view text, const std::string& name);

  ConfigDocument(ConfigDocument&&) noexcept;
  ConfigDocument& operator=(ConfigDocument&&) noexcept;
  ~ConfigDocument();

  ConfigSection root() const;
  /// Throws if any key in the file was not read by the schema (unknown or misspelled),
  /// with a "did you mean" hint when a known key is close.
  void finish() const;
  const std::string& name() const { return name_; }

 private:
  friend class ConfigSection;
  ConfigDocument() = default;
  void mark_used(const std::string& path) const { used_->insert(path); }
  std::string where(const toml::node* node) const;

  std::string name_;
  std::unique_ptr<toml::table> table_;
  std::unique_ptr<std::set<std::string>> used_ = std::make_unique<std::set<std::string>>();
};

/// Edit distance, for "did you mean" hints.
std::size_t edit_distance(std::string_view a, std::string_view b);

}  // namespace cairn
