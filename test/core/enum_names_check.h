// The check every enumeration's names pass (core, ROS and tools tests): each name reads back
// as its value, through the names and through the enumeration's own Parse function, and an
// unknown name is refused with a message that names every choice.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <set>
#include <stdexcept>
#include <string>

#include "bsf_vpr/core/enum_names.h"

namespace bsf_vpr {
namespace testing {

// `parse` is the enumeration's Parse* function (or null for names that are only shown, such
// as the causes of a lost pose). The enumerators are numbered 0..N-1 (none has a value of
// its own), so a table that misses one has a value without a name.
template <typename E>
void ExpectNamesRoundTrip(const EnumNames<E>& names, E (*parse)(const std::string&),
                          const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_FALSE(names.entries().empty());
  std::set<std::string> seen;
  for (const auto& [value, name] : names.entries()) {
    EXPECT_TRUE(seen.insert(name).second) << "twice: " << name;
    EXPECT_EQ(names.Find(name), value) << name;
    EXPECT_EQ(names.Parse(name, what), value) << name;
    EXPECT_EQ(names.Name(names.Parse(name, what)), std::string(name));
    if (parse != nullptr) {
      EXPECT_EQ(parse(name), value) << name;
    }
  }
  for (size_t i = 0; i < names.entries().size(); ++i) {
    EXPECT_NO_THROW(names.Name(static_cast<E>(i))) << "value " << i << " has no name";
  }
  EXPECT_EQ(names.Choices().size(), names.entries().size());

  const std::string unknown = "no such name";
  EXPECT_FALSE(names.Find(unknown).has_value());
  const auto expect_refused = [&](const std::function<void()>& f) {
    try {
      f();
      ADD_FAILURE() << "'" << unknown << "' was accepted";
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(unknown), std::string::npos) << message;
      for (const std::string& choice : names.Choices()) {
        EXPECT_NE(message.find(choice), std::string::npos) << choice << " in " << message;
      }
    }
  };
  expect_refused([&] { names.Parse(unknown, what); });
  if (parse != nullptr) {
    expect_refused([&] { parse(unknown); });
  }
}

}  // namespace testing
}  // namespace bsf_vpr
