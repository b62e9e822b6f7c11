// The names of an enumeration's values, written once: an option table's choices
// (OptionTable::AddChoice), the enumeration's Parse* and ToString functions and their error
// messages all read the one EnumNames of the enumeration.
#pragma once

#include <initializer_list>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace bsf_vpr {

template <typename E>
class EnumNames {
 public:
  using Entry = std::pair<E, const char*>;

  // Every value with its name, in the order the choices are shown (docs, usage, messages).
  EnumNames(std::initializer_list<Entry> entries) : entries_(entries) {}

  const std::vector<Entry>& entries() const { return entries_; }

  // The value named `name` (exactly), or nullopt.
  std::optional<E> Find(const std::string& name) const {
    for (const Entry& e : entries_) {
      if (name == e.second) return e.first;
    }
    return std::nullopt;
  }

  // The value named `name`. Throws std::invalid_argument naming `what` (the option or
  // field) and the choices: "fusion must be mixture or product, got 'sum'".
  E Parse(const std::string& name, const std::string& what) const {
    if (const std::optional<E> e = Find(name)) return *e;
    throw std::invalid_argument(what + " must be " + Listed() + ", got '" + name + "'");
  }

  // The name of `value`. Throws std::logic_error for a value without one (the table misses
  // an enumerator: a bug, not a caller's mistake).
  const char* Name(E value) const {
    for (const Entry& e : entries_) {
      if (e.first == value) return e.second;
    }
    throw std::logic_error("an enumeration value has no name (first of its names: " +
                           std::string(entries_.empty() ? "none" : entries_.front().second) + ")");
  }

  // The names, in order.
  std::vector<std::string> Choices() const {
    std::vector<std::string> out;
    for (const Entry& e : entries_) out.emplace_back(e.second);
    return out;
  }

  // The names as a phrase: "a, b or c" (the separators are given for other forms, e.g.
  // " | " and " | " for "a | b | c").
  std::string Listed(const std::string& separator = ", ", const std::string& last = " or ") const {
    std::string out;
    for (size_t i = 0; i < entries_.size(); ++i) {
      if (i > 0) out += i + 1 == entries_.size() ? last : separator;
      out += entries_[i].second;
    }
    return out;
  }

 private:
  std::vector<Entry> entries_;
};

}  // namespace bsf_vpr
