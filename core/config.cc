#include "core/config.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "core/decimal.h"
#include "core/error.h"
#include "core/file_io.h"

namespace curvecheck {
namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string Show(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return "nothing";
}

}  // namespace

ConfigMap::ConfigMap(YAML::Node node, std::string source, std::string path)
    : node_(std::move(node)), source_(std::move(source)), path_(std::move(path)) {}

ConfigMap ConfigMap::Parse(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(source, fmt::format("not valid YAML at line {}, column {}: {}", e.mark.line + 1, e.mark.column + 1,
                                    e.msg),
                "fix the syntax (JSON is accepted too)");
  }
  if (!root.IsMap()) {
    throw Error(source, "expected a mapping of keys at the top level, found " + Show(root),
                "see datasets/monitors/ for an example");
  }
  return ConfigMap(root, source, "");
}

ConfigMap ConfigMap::Load(const std::filesystem::path& path) { return Parse(ReadFileToString(path), path.string()); }

std::string ConfigMap::KeyPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

void ConfigMap::Fail(const std::string& key, const std::string& problem, const std::string& fix) const {
  throw Error(source_, fmt::format("key '{}' {}", KeyPath(key), problem), fix);
}

bool ConfigMap::Has(const std::string& key) const {
  const YAML::Node n = node_[key];
  return n.IsDefined() && !n.IsNull();
}

YAML::Node ConfigMap::Get(const std::string& key) const {
  const YAML::Node n = node_[key];
  if (!n.IsDefined() || n.IsNull()) Fail(key, "is missing", "add it");
  return n;
}

void ConfigMap::RejectUnknownKeys(std::initializer_list<const char*> known) const {
  for (const auto& kv : node_) {
    const std::string k = kv.first.Scalar();
    if (std::none_of(known.begin(), known.end(), [&](const char* q) { return k == q; })) {
      std::string list;
      for (const char* q : known) list += (list.empty() ? "" : ", ") + std::string(q);
      Fail(k, "is not a known key", "expected one of: " + list);
    }
  }
}

ConfigMap ConfigMap::Map(const std::string& key) const {
  const YAML::Node n = Get(key);
  if (!n.IsMap()) Fail(key, "must be a mapping, got " + Show(n), "see the documentation of this key");
  return ConfigMap(n, source_, KeyPath(key));
}

std::vector<ConfigMap> ConfigMap::MapList(const std::string& key) const {
  const YAML::Node n = Get(key);
  if (!n.IsSequence()) Fail(key, "must be a list, got " + Show(n), "write a list of mappings");
  std::vector<ConfigMap> out;
  for (size_t i = 0; i < n.size(); ++i) {
    if (!n[i].IsMap()) Fail(fmt::format("{}[{}]", key, i), "must be a mapping, got " + Show(n[i]), "write key: value pairs");
    out.push_back(ConfigMap(n[i], source_, KeyPath(fmt::format("{}[{}]", key, i))));
  }
  return out;
}

std::string ConfigMap::String(const std::string& key) const {
  const YAML::Node n = Get(key);
  if (!n.IsScalar()) Fail(key, "must be a text, got " + Show(n), "write a single value");
  return n.Scalar();
}

double ConfigMap::ToNumber(const YAML::Node& n, const std::string& key) const {
  if (!n.IsScalar()) Fail(key, "must be a number, got " + Show(n), "write a single number");
  // Parse ourselves: yaml-cpp accepts ".nan"/".inf" and would hand them on silently.
  const std::string& s = n.Scalar();
  const std::string low = Lower(s);
  for (const char* word : {".nan", ".inf", "+.inf", "-.inf", "nan", "inf", "+inf", "-inf", "infinity", "-infinity"}) {
    if (low == word) Fail(key, "is '" + s + "', not a finite number", "write a finite number");
  }
  // Decimal only (decimal.h): strtod would read 0x10 as 16.
  const std::optional<double> v = ParseDecimal(s);
  if (!v) {
    const std::string problem = DecimalProblem(s);
    if (problem.ends_with("is not a finite number")) Fail(key, "is '" + s + "', not a finite number", "write a finite number");
    if (problem.ends_with("is out of range")) Fail(key, "is '" + s + "', beyond the range of numbers", "write a finite number");
    Fail(key, fmt::format("must be a {}number, got '{}'", problem.ends_with("not a decimal number") ? "decimal " : "", s),
         "write a number such as 1000 or 12.5");
  }
  return *v;
}

double ConfigMap::Number(const std::string& key) const { return ToNumber(Get(key), key); }

double ConfigMap::PositiveNumber(const std::string& key) const {
  const double v = Number(key);
  if (!(v > 0)) Fail(key, fmt::format("is {}, but must be greater than zero", v), "give a positive value");
  return v;
}

int ConfigMap::PositiveInt(const std::string& key) const {
  const double v = Number(key);
  if (v != std::floor(v) || v < 1 || v > 1e9) {
    Fail(key, fmt::format("is {}, but must be a whole number of at least 1", v), "give a positive integer");
  }
  return static_cast<int>(v);
}

std::vector<double> ConfigMap::Numbers(const std::string& key, size_t n) const {
  const YAML::Node seq = Get(key);
  if (!seq.IsSequence() || seq.size() != n) {
    Fail(key, fmt::format("must be a list of {} numbers, got {}", n, Show(seq)), fmt::format("write [a, b{}]", n > 2 ? ", ..." : ""));
  }
  std::vector<double> out;
  for (size_t i = 0; i < n; ++i) out.push_back(ToNumber(seq[i], fmt::format("{}[{}]", key, i)));
  return out;
}

std::vector<int> ConfigMap::PositiveInts(const std::string& key, size_t n) const {
  const std::vector<double> v = Numbers(key, n);
  std::vector<int> out;
  for (size_t i = 0; i < n; ++i) {
    if (v[i] != std::floor(v[i]) || v[i] < 1 || v[i] > 1e9) {
      Fail(fmt::format("{}[{}]", key, i), fmt::format("is {}, but must be a whole number of at least 1", v[i]),
           "give positive integers");
    }
    out.push_back(static_cast<int>(v[i]));
  }
  return out;
}

bool ConfigMap::IsWord(const std::string& key, const std::string& word) const {
  const YAML::Node n = node_[key];
  return n.IsDefined() && n.IsScalar() && Lower(n.Scalar()) == Lower(word);
}

std::vector<double> ParseNumberList(const std::string& text, size_t n, const std::string& option) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    const std::string t = b == std::string::npos ? "" : item.substr(b, e - b + 1);
    const std::optional<double> v = ParseDecimal(t);
    if (!v) {
      const std::string problem = DecimalProblem(t);
      if (problem.ends_with("is not a finite number") || problem.ends_with("is out of range")) {
        throw Error(option, fmt::format("'{}' is not finite in '{}'", t, text), "write finite numbers");
      }
      throw Error(option, fmt::format("{} in '{}'", problem, text),
                  fmt::format("write {} decimal numbers separated by commas", n));
    }
    out.push_back(*v);
  }
  if (out.size() != n) {
    throw Error(option, fmt::format("expected {} numbers, got {} in '{}'", n, out.size(), text),
                fmt::format("write {} numbers separated by commas, e.g. 0,0,500", n));
  }
  return out;
}

std::vector<std::string> SplitList(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::stringstream parts(text);
  for (std::string p; std::getline(parts, p, separator);) {
    if (!p.empty()) out.push_back(p);
  }
  return out;
}

}  // namespace curvecheck
