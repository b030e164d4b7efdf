// Typed, validated access to YAML configuration files (JSON is valid YAML and is accepted).
//
// Nothing here has a silent default: a missing key, a value of the wrong type, NaN or infinity, a size that
// is zero or negative, or a key that is not expected (usually a typo) all throw Error with the file, the key
// path and what to do. Callers decide which keys are optional by testing Has() first.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

namespace curvecheck {

// A mapping node of a config file, with where it came from for error messages.
class ConfigMap {
 public:
  // Parses YAML text; `source` names it in errors (a file path, or "preset 'x'"). Throws Error on syntax
  // errors (with line and column) and if the document is not a mapping.
  static ConfigMap Parse(const std::string& text, const std::string& source);
  // Reads and parses a file.
  static ConfigMap Load(const std::filesystem::path& path);

  const std::string& source() const { return source_; }
  // Dotted path of this node inside the document ("" for the root).
  const std::string& path() const { return path_; }

  bool Has(const std::string& key) const;
  // Throws unless every key of the mapping is one of `known`.
  void RejectUnknownKeys(std::initializer_list<const char*> known) const;

  ConfigMap Map(const std::string& key) const;
  // A sequence of mappings (e.g. a list of bumps); each element named "key[i]" in errors.
  std::vector<ConfigMap> MapList(const std::string& key) const;
  std::string String(const std::string& key) const;
  // A finite number.
  double Number(const std::string& key) const;
  // A finite number > 0.
  double PositiveNumber(const std::string& key) const;
  // An integer >= 1.
  int PositiveInt(const std::string& key) const;
  // A sequence of exactly n finite numbers.
  std::vector<double> Numbers(const std::string& key, size_t n) const;
  // A sequence of exactly n integers >= 1.
  std::vector<int> PositiveInts(const std::string& key, size_t n) const;
  // True if the value is the given word (e.g. radius_mm: flat), compared without case.
  bool IsWord(const std::string& key, const std::string& word) const;

  // Throws Error "source: key 'path.key' problem; fix".
  [[noreturn]] void Fail(const std::string& key, const std::string& problem, const std::string& fix) const;

 private:
  ConfigMap(YAML::Node node, std::string source, std::string path);
  YAML::Node Get(const std::string& key) const;  // throws if missing or null
  std::string KeyPath(const std::string& key) const;
  double ToNumber(const YAML::Node& n, const std::string& key) const;

  YAML::Node node_;
  std::string source_;
  std::string path_;
};

// Parses "x,y,z" (spaces allowed) into exactly n finite numbers; throws Error naming `option`.
std::vector<double> ParseNumberList(const std::string& text, size_t n, const std::string& option);

// The non-empty parts of a list option ("flat,cylinder" -> {"flat", "cylinder"}; "a,,b" -> {"a", "b"}).
std::vector<std::string> SplitList(const std::string& text, char separator = ',');

}  // namespace curvecheck
