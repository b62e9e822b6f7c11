#include "bsf_vpr/core/options.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace bsf_vpr {
namespace {

const char* TypeName(OptionType type) {
  switch (type) {
    case OptionType::kBool:
      return "true or false";
    case OptionType::kInt:
      return "a whole number";
    case OptionType::kDouble:
      return "a number";
    case OptionType::kString:
    case OptionType::kChoice:
    case OptionType::kExternal:
      return "a string";
    case OptionType::kDoubleList:
      return "a list of numbers";
  }
  return "?";
}

double ParseDouble(const std::string& text, const std::string& shown) {
  errno = 0;
  char* end = nullptr;
  const double v = text.empty() ? 0 : std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
    throw std::invalid_argument(shown + " expects a number, got '" + text + "'");
  }
  return v;
}

// The shortest decimal text that reads back as `v` (1000, 0.04, 1e-09).
std::string PlainNumber(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  char buffer[64];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, r.ptr);
}

// The same, recognisable as a double in YAML and Python (1 -> 1.0).
std::string ShortestDouble(double v) {
  std::string t = PlainNumber(v);
  if (t.find_first_of(".eEn") == std::string::npos) t += ".0";
  return t;
}

std::string Wrap(const std::string& text, size_t width, const std::string& indent) {
  std::string out;
  for (const std::string& line : WrapWords(text, width)) {
    out += (out.empty() ? "" : "\n" + indent) + line;
  }
  return out;
}

}  // namespace

double FloatAsDecimal(float f) {
  if (!std::isfinite(f)) return static_cast<double>(f);
  char buffer[64];
  const std::to_chars_result r = std::to_chars(buffer, buffer + sizeof(buffer), f);
  return std::strtod(std::string(buffer, r.ptr).c_str(), nullptr);
}

std::vector<std::string> WrapWords(const std::string& text, size_t width) {
  std::istringstream words(text);
  std::vector<std::string> lines;
  std::string line, word;
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

std::string OptionFlag(const std::string& name) {
  std::string flag = "--" + name;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

std::string OptionNameFromFlag(const std::string& flag) {
  if (flag.rfind("--", 0) != 0) return "";
  std::string name = flag.substr(2);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

std::string FormatOptionValue(const OptionValue& value) {
  struct Visitor {
    std::string operator()(bool v) const { return v ? "true" : "false"; }
    std::string operator()(long long v) const { return std::to_string(v); }
    std::string operator()(double v) const { return ShortestDouble(v); }
    std::string operator()(const std::string& v) const { return v; }
    std::string operator()(const std::vector<double>& v) const {
      std::string out;
      for (size_t i = 0; i < v.size(); ++i) out += (i ? "," : "") + ShortestDouble(v[i]);
      return out;
    }
  };
  return std::visit(Visitor{}, value);
}

OptionValue ParseOptionText(const OptionInfo& info, const std::string& text,
                            const std::string& shown) {
  switch (info.type) {
    case OptionType::kBool:
      if (text == "true" || text == "1") return true;
      if (text == "false" || text == "0") return false;
      throw std::invalid_argument(shown + " expects true or false, got '" + text + "'");
    case OptionType::kInt: {
      errno = 0;
      char* end = nullptr;
      const long long v = text.empty() ? 0 : std::strtoll(text.c_str(), &end, 10);
      if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
        throw std::invalid_argument(shown + " expects a whole number, got '" + text + "'");
      }
      return v;
    }
    case OptionType::kDouble:
      return ParseDouble(text, shown);
    case OptionType::kDoubleList: {
      std::vector<double> v;
      std::stringstream items(text);
      for (std::string item; std::getline(items, item, ',');) v.push_back(ParseDouble(item, shown));
      return v;
    }
    case OptionType::kString:
    case OptionType::kChoice:
    case OptionType::kExternal:
      return text;
  }
  return text;
}

OptionValue ConvertOptionValue(const OptionValue& value, OptionType type,
                               const std::string& shown) {
  const auto wrong = [&]() {
    return std::invalid_argument(shown + " must be " + TypeName(type) + ", got '" +
                                 FormatOptionValue(value) + "'");
  };
  switch (type) {
    case OptionType::kBool:
      if (!std::holds_alternative<bool>(value)) throw wrong();
      return value;
    case OptionType::kInt:
      if (!std::holds_alternative<long long>(value)) throw wrong();
      return value;
    case OptionType::kDouble:
      if (std::holds_alternative<long long>(value)) {
        return static_cast<double>(std::get<long long>(value));
      }
      if (!std::holds_alternative<double>(value)) throw wrong();
      return value;
    case OptionType::kDoubleList:
      if (!std::holds_alternative<std::vector<double>>(value)) throw wrong();
      return value;
    case OptionType::kString:
    case OptionType::kChoice:
    case OptionType::kExternal:
      if (!std::holds_alternative<std::string>(value)) throw wrong();
      return value;
  }
  throw wrong();
}

void CheckOptionValue(const OptionInfo& info, const OptionValue& value, const std::string& shown) {
  ConvertOptionValue(value, info.type, shown);  // throws for a value of another type
  const OptionBounds& b = info.bounds;
  const auto check = [&](double x) {
    if (b.finite && !std::isfinite(x)) {
      const std::string range = DescribeRange(info);
      throw std::invalid_argument(shown + " must be a finite number" +
                                  (range.empty() ? "" : " " + range) + ", got " + PlainNumber(x));
    }
    if (std::isnan(x)) {  // an option without bounds still needs a number
      const std::string range = DescribeRange(info);
      throw std::invalid_argument(shown + " must be a number" + (range.empty() ? "" : " " + range) +
                                  ", got nan");
    }
    const bool low = b.min_open ? !(x > b.min) : !(x >= b.min);
    const bool high = b.max_open ? !(x < b.max) : !(x <= b.max);
    if (low || high) {
      throw std::invalid_argument(shown + " must be " + DescribeRange(info) + ", got " +
                                  PlainNumber(x));
    }
  };
  switch (info.type) {
    case OptionType::kInt: {
      const long long v = std::get<long long>(value);
      if (v < INT_MIN || v > INT_MAX) {
        throw std::invalid_argument(shown + " is out of range: " + std::to_string(v));
      }
      check(static_cast<double>(v));
      break;
    }
    case OptionType::kDouble:
      check(std::get<double>(value));
      break;
    case OptionType::kDoubleList:
      for (double x : std::get<std::vector<double>>(value)) check(x);
      break;
    case OptionType::kChoice: {
      const std::string& v = std::get<std::string>(value);
      if (std::find(info.choices.begin(), info.choices.end(), v) == info.choices.end()) {
        throw std::invalid_argument(shown + " must be " + DescribeRange(info) + ", got '" + v +
                                    "'");
      }
      break;
    }
    default:
      break;
  }
}

std::string DescribeRange(const OptionInfo& info) {
  if (info.type == OptionType::kChoice) {
    std::string out;
    for (const std::string& c : info.choices) {
      out += (out.empty() ? "" : " | ") + (c.empty() ? std::string("\"\"") : c);
    }
    return out;
  }
  const OptionBounds& b = info.bounds;
  const bool has_min = std::isfinite(b.min), has_max = std::isfinite(b.max);
  const std::string lo = PlainNumber(b.min), hi = PlainNumber(b.max);
  if (has_min && has_max) {
    return std::string(b.min_open ? "in (" : "in [") + lo + ", " + hi + (b.max_open ? ")" : "]");
  }
  if (has_min) return std::string(b.min_open ? "> " : ">= ") + lo;
  if (has_max) return std::string(b.max_open ? "< " : "<= ") + hi;
  return "";
}

std::string OptionsUsage(const std::vector<OptionInfo>& options) {
  std::string out;
  for (const OptionInfo& o : options) {
    if (o.type == OptionType::kExternal) continue;
    std::string head = "  " + OptionFlag(o.name) + " ";
    switch (o.type) {
      case OptionType::kBool:
        head += "true|false";
        break;
      case OptionType::kChoice:
        head += DescribeRange(o);
        break;
      case OptionType::kDoubleList:
        head += "X,Y,...";
        break;
      case OptionType::kInt:
        head += "N";
        break;
      case OptionType::kDouble:
        head += "X";
        break;
      default:
        head += "TEXT";
        break;
    }
    std::string text = o.doc;
    if (!o.unit.empty()) text += " (" + o.unit + ")";
    const std::string range = o.type == OptionType::kChoice ? "" : DescribeRange(o);
    if (!range.empty()) text += "; " + range;
    const std::string def = FormatOptionValue(o.default_value);
    text += "; default " + (def.empty() ? "\"\"" : def);
    const std::string indent(26, ' ');
    if (head.size() >= 26) {
      out += head + "\n" + indent;
    } else {
      out += head + std::string(26 - head.size(), ' ');
    }
    out += Wrap(text, 92 - 26, indent) + "\n";
  }
  return out;
}

std::optional<OptionValue> NamedValueSource::Get(const std::string& name, OptionType type) {
  for (const auto& [key, value] : values_) {
    if (key != name) continue;
    if (std::find(read_.begin(), read_.end(), name) == read_.end()) read_.push_back(name);
    return ConvertOptionValue(value, type, Describe(name));
  }
  return std::nullopt;
}

std::vector<std::string> NamedValueSource::Unread() const {
  std::vector<std::string> out;
  for (const auto& kv : values_) {
    if (std::find(read_.begin(), read_.end(), kv.first) == read_.end()) out.push_back(kv.first);
  }
  return out;
}

}  // namespace bsf_vpr
