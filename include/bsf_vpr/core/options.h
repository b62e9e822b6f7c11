// Options declared once. Each options struct has one table: for every option its name
// (snake_case; the ROS parameter, and the command-line flag with dashes: gamma_fraction is
// --gamma-fraction), its type, unit, documentation, bounds or choices and whether it can be
// changed while running (dynamic_reconfigure). The default is the struct's own default
// member value. The ROS parameter loader, the command-line flags and their usage text, the
// dynamic_reconfigure description (cfg/Fusion.cfg) and the documented config files are
// all derived from the tables (tools/bsf_options writes the derived files; a test checks
// that the committed ones are current).
//
// Reading is tracked, not listed: a source remembers which keys were read, and a key that
// no table read is refused (as cartographer's LuaParameterDictionary refuses unused keys).
#pragma once

#include <algorithm>
#include <functional>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "bsf_vpr/core/enum_names.h"

namespace bsf_vpr {

enum class OptionType {
  kBool,
  kInt,
  kDouble,
  kString,
  kChoice,      // a string from a fixed list (an enumeration)
  kDoubleList,  // a list of numbers
  kExternal,    // documented here, read by code of its own (e.g. a list of mappings)
};

using OptionValue = std::variant<bool, long long, double, std::string, std::vector<double>>;

// Inclusive or open bounds of a number.
struct OptionBounds {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  // the value must be > min (else >= min)
  bool max_open = false;
  bool finite = false;  // refuse infinity too (else a side without a bound admits it)
};
inline OptionBounds AtLeast(double min) { return {min}; }
inline OptionBounds Above(double min) {
  return {min, std::numeric_limits<double>::infinity(), true};
}
inline OptionBounds Between(double min, double max) { return {min, max}; }
// `bounds`, and a finite number: Finite(AtLeast(0)) is a finite number >= 0.
inline OptionBounds Finite(OptionBounds bounds = {}) {
  bounds.finite = true;
  return bounds;
}

// What a table says about one option, without the struct it belongs to.
struct OptionInfo {
  std::string name;
  OptionType type = OptionType::kString;
  std::string doc;
  std::string unit;  // e.g. "places", "m", "px"; "" for unitless
  OptionBounds bounds;
  std::vector<std::string> choices;  // kChoice
  bool live = false;                 // may change while running (dynamic_reconfigure)
  OptionValue default_value;         // the struct's default (kExternal: its text)
};

// The double written with the shortest decimal that reads back as `f` (0.485f is
// 0.485000014305 as a double; this gives 0.485).
double FloatAsDecimal(float f);

// "--gamma-fraction" for "gamma_fraction", and back ("--gamma_fraction" is accepted too).
std::string OptionFlag(const std::string& name);
std::string OptionNameFromFlag(const std::string& flag);

// The value as a user writes it: true, 12, 0.04, bsf, 0.485,0.456,0.406.
std::string FormatOptionValue(const OptionValue& value);
// Parses a command-line value of `info`'s type (not checked against the bounds). Throws
// std::invalid_argument naming `shown` (how the option appears to the user).
OptionValue ParseOptionText(const OptionInfo& info, const std::string& text,
                            const std::string& shown);
// Throws std::invalid_argument naming `shown` when `value` is out of bounds, not among
// the choices, or not of the option's type.
void CheckOptionValue(const OptionInfo& info, const OptionValue& value, const std::string& shown);
// "0 <= x", "(0, 1]", "bsf | cosine": the bounds or choices as text ("" if none).
std::string DescribeRange(const OptionInfo& info);

// Where option values come from: ROS parameters, dynamic_reconfigure, a test's table.
class OptionSource {
 public:
  virtual ~OptionSource() = default;
  // The value given for `name`, or nullopt when none is; marks `name` as read. Throws
  // std::invalid_argument naming the option when the value is not of `type` (a whole
  // number is accepted for a double).
  virtual std::optional<OptionValue> Get(const std::string& name, OptionType type) = 0;
  // How `name` is shown to the user ("/bsf_vpr/gamma_fraction").
  virtual std::string Describe(const std::string& name) const = 0;
};

// `text`'s words in lines of at most `width` characters (a longer word has a line of its own).
std::vector<std::string> WrapWords(const std::string& text, size_t width);

// The usage lines of `options` for a tool's --help: the flag at column 3, the text at
// column 27, with default, unit and range.
std::string OptionsUsage(const std::vector<OptionInfo>& options);

// OptionTable::Include's field for a base class of the including struct: the Base part of
// a struct, const or not.
template <typename Base>
struct AsBase {
  template <typename S>
  Base& operator()(S& v) const {
    return v;
  }
  template <typename S>
  const Base& operator()(const S& v) const {
    return v;
  }
};

template <typename S>
class OptionTable {
 public:
  struct Spec {
    OptionInfo info;
    std::function<OptionValue(const S&)> get;
    std::function<void(S&, const OptionValue&)> set;  // the value has been checked
  };

  // One option of the struct. `field` is a lambda that returns a reference to the member,
  // for a const and a non-const S (write it `[](auto& s) -> auto& { return s.a.b; }`).
  // The member is bool, int, double, std::string or std::vector<float or double>.
  template <typename Field>
  OptionTable& Add(const std::string& name, Field field, const std::string& doc,
                   const std::string& unit = "", OptionBounds bounds = {}, bool live = false) {
    using T = std::decay_t<decltype(field(std::declval<S&>()))>;
    Spec s;
    s.info = {name, TypeOf<T>(), doc, unit, bounds, {}, live, OptionValue()};
    s.get = [field](const S& v) { return ToValue(field(v)); };
    s.set = [field](S& v, const OptionValue& x) { FromValue(x, &field(v)); };
    return Push(std::move(s));
  }

  // An enumeration, given as one of the names of `names` (and written so in every derived
  // file). The member is E; or std::optional<E>, where the choice "" (shown first) is none;
  // or a std::string holding one of the names, for a struct that keeps the text (a value
  // not among them is refused by CheckValues).
  template <typename Field, typename E>
  OptionTable& AddChoice(const std::string& name, Field field, const std::string& doc,
                         const EnumNames<E>& names, bool live = false) {
    using T = std::decay_t<decltype(field(std::declval<S&>()))>;
    static_assert(std::is_same_v<T, E> || std::is_same_v<T, std::optional<E>> ||
                      std::is_same_v<T, std::string>,
                  "a choice is stored as its enumeration, std::optional of it or its name");
    std::vector<std::string> choices = names.Choices();
    if constexpr (std::is_same_v<T, std::optional<E>>) choices.insert(choices.begin(), "");
    Spec s;
    s.info = {name, OptionType::kChoice, doc, "", {}, std::move(choices), live, OptionValue()};
    s.get = [field, names](const S& v) {
      const T& x = field(v);
      if constexpr (std::is_same_v<T, std::string>) {
        return OptionValue(x);
      } else if constexpr (std::is_same_v<T, std::optional<E>>) {
        return OptionValue(std::string(x ? names.Name(*x) : ""));
      } else {
        return OptionValue(std::string(names.Name(x)));
      }
    };
    s.set = [field, names, name](S& v, const OptionValue& x) {
      const std::string& text = std::get<std::string>(x);  // one of the choices
      if constexpr (std::is_same_v<T, std::string>) {
        field(v) = text;
      } else if constexpr (std::is_same_v<T, std::optional<E>>) {
        field(v) = text.empty() ? std::nullopt : std::optional<E>(names.Parse(text, name));
      } else {
        field(v) = names.Parse(text, name);
      }
    };
    return Push(std::move(s));
  }

  // An option read by code of its own (a list of mappings, a parameter another library
  // reads); the table documents it and a source marks it read when that code reads it.
  OptionTable& AddExternal(const std::string& name, const std::string& doc,
                           const std::string& default_text) {
    Spec s;
    s.info = {name, OptionType::kExternal, doc, "", {}, {}, false, OptionValue(default_text)};
    return Push(std::move(s));
  }

  // Every option of `sub`, a table of the member (or base, AsBase) that `field` returns, but
  // those named in
  // `except` (which the including struct declares with a meaning of its own).
  template <typename Sub, typename Field>
  OptionTable& Include(const OptionTable<Sub>& sub, Field field,
                       const std::vector<std::string>& except = {}) {
    for (const typename OptionTable<Sub>::Spec& c : sub.specs()) {
      if (std::find(except.begin(), except.end(), c.info.name) != except.end()) continue;
      Spec s;
      s.info = c.info;
      if (c.get) {
        s.get = [field, g = c.get](const S& v) { return g(field(v)); };
        s.set = [field, st = c.set](S& v, const OptionValue& x) { st(field(v), x); };
      }
      Push(std::move(s));
    }
    return *this;
  }

  const std::vector<Spec>& specs() const { return specs_; }
  const Spec* Find(const std::string& name) const {
    for (const Spec& s : specs_) {
      if (s.info.name == name) return &s;
    }
    return nullptr;
  }
  std::vector<OptionInfo> Infos(bool live_only = false) const {
    std::vector<OptionInfo> out;
    for (const Spec& s : specs_) {
      if (!live_only || s.info.live) out.push_back(s.info);
    }
    return out;
  }

  // Reads every option `source` gives (kExternal ones excepted) into `out`, checking each
  // value; with live_only, only the live ones. Throws std::invalid_argument naming the
  // option; `out` may then be partly changed (apply to a copy to keep the original).
  void Apply(OptionSource& source, S* out, bool live_only = false) const {
    for (const Spec& s : specs_) {
      if (!s.set || (live_only && !s.info.live)) continue;
      const std::optional<OptionValue> v = source.Get(s.info.name, s.info.type);
      if (!v) continue;
      CheckOptionValue(s.info, *v, source.Describe(s.info.name));
      s.set(*out, *v);
    }
  }

  // Sets the option of command-line `flag` (--name-with-dashes) from `text` and returns
  // true; returns false, changing nothing, when no option of the table has that flag.
  // Throws std::invalid_argument naming the flag for a bad value.
  bool SetFromFlag(const std::string& flag, const std::string& text, S* out) const {
    const Spec* s = Find(OptionNameFromFlag(flag));
    if (s == nullptr || !s->set) return false;
    const OptionValue v = ParseOptionText(s->info, text, flag);
    CheckOptionValue(s->info, v, flag);
    s->set(*out, v);
    return true;
  }

  // Checks every value of `options` as Apply checks a value given (bounds, choices):
  // the checks of single fields in a Validate(), for options built in code as for options
  // read. Throws std::invalid_argument naming the option.
  void CheckValues(const S& options) const {
    for (const Spec& s : specs_) {
      if (s.get) CheckOptionValue(s.info, s.get(options), s.info.name);
    }
  }
  // The same for the option `name` alone, shown as `shown` (e.g. a field's own name).
  void CheckValue(const S& options, const std::string& name, const std::string& shown) const {
    const Spec* s = Find(name);
    if (s == nullptr || !s->get) throw std::logic_error("no option '" + name + "' to check");
    CheckOptionValue(s->info, s->get(options), shown);
  }

  // The values of `options` (its options that are not external), by name.
  std::vector<std::pair<std::string, OptionValue>> Values(const S& options,
                                                          bool live_only = false) const {
    std::vector<std::pair<std::string, OptionValue>> out;
    for (const Spec& s : specs_) {
      if (s.get && (!live_only || s.info.live)) out.emplace_back(s.info.name, s.get(options));
    }
    return out;
  }

 private:
  OptionTable& Push(Spec s) {
    if (s.get) {
      const S defaults;  // a named object: GCC 12 warns falsely about a temporary's strings
      s.info.default_value = s.get(defaults);
    }
    specs_.push_back(std::move(s));
    return *this;
  }

  template <typename T>
  static constexpr OptionType TypeOf() {
    if constexpr (std::is_same_v<T, bool>) return OptionType::kBool;
    if constexpr (std::is_same_v<T, int>) return OptionType::kInt;
    if constexpr (std::is_same_v<T, double>) return OptionType::kDouble;
    if constexpr (std::is_same_v<T, std::string>) return OptionType::kString;
    static_assert(std::is_same_v<T, bool> || std::is_same_v<T, int> || std::is_same_v<T, double> ||
                      std::is_same_v<T, std::string> || std::is_same_v<T, std::vector<float>> ||
                      std::is_same_v<T, std::vector<double>>,
                  "an option is bool, int, double, std::string or a std::vector of them");
    return OptionType::kDoubleList;
  }
  static OptionValue ToValue(bool v) { return v; }
  static OptionValue ToValue(int v) { return static_cast<long long>(v); }
  static OptionValue ToValue(double v) { return v; }
  static OptionValue ToValue(const std::string& v) { return v; }
  static OptionValue ToValue(const std::vector<float>& v) {
    std::vector<double> out;
    for (float f : v) out.push_back(FloatAsDecimal(f));  // 0.485f shows as 0.485
    return out;
  }
  static OptionValue ToValue(const std::vector<double>& v) { return v; }
  static void FromValue(const OptionValue& x, std::vector<double>* v) {
    *v = std::get<std::vector<double>>(x);
  }
  static void FromValue(const OptionValue& x, bool* v) { *v = std::get<bool>(x); }
  static void FromValue(const OptionValue& x, int* v) {
    *v = static_cast<int>(std::get<long long>(x));  // CheckOptionValue kept it in int range
  }
  static void FromValue(const OptionValue& x, double* v) { *v = std::get<double>(x); }
  static void FromValue(const OptionValue& x, std::string* v) { *v = std::get<std::string>(x); }
  static void FromValue(const OptionValue& x, std::vector<float>* v) {
    const std::vector<double>& d = std::get<std::vector<double>>(x);
    v->assign(d.begin(), d.end());
  }

  std::vector<Spec> specs_;
};

// A source over values given by name (tests, dynamic_reconfigure's Config message once
// converted), tracking what was read.
class NamedValueSource : public OptionSource {
 public:
  explicit NamedValueSource(std::vector<std::pair<std::string, OptionValue>> values,
                           std::string prefix = "")
      : values_(std::move(values)), prefix_(std::move(prefix)) {}
  std::optional<OptionValue> Get(const std::string& name, OptionType type) override;
  std::string Describe(const std::string& name) const override { return prefix_ + name; }
  // The names given that no Get asked for.
  std::vector<std::string> Unread() const;

 private:
  std::vector<std::pair<std::string, OptionValue>> values_;
  std::string prefix_;
  std::vector<std::string> read_;
};

// Converts a value given with another representation to `type` where that is exact (a
// whole number for a double, a list of whole numbers for a list). Throws
// std::invalid_argument naming `shown` otherwise.
OptionValue ConvertOptionValue(const OptionValue& value, OptionType type, const std::string& shown);

}  // namespace bsf_vpr
