// Text safe to put in a message: quoting, and where a text stops being readable (declared in
// data_directory.h, whose paths and names these quote).
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>

#include "bsf_vpr/io/data_directory.h"

namespace bsf_vpr {

namespace {

// The code point of the UTF-8 sequence at text[i] and its length in bytes, or length 0 when
// the bytes there are not valid UTF-8 (cut short, overlong, a surrogate, beyond U+10FFFF).
std::pair<uint32_t, size_t> DecodeUtf8(const std::string& text, size_t i) {
  const unsigned char c = static_cast<unsigned char>(text[i]);
  if (c < 0x80) return {c, 1};
  size_t extra = 0;
  uint32_t cp = 0;
  if ((c & 0xe0) == 0xc0) {
    extra = 1;
    cp = c & 0x1f;
  } else if ((c & 0xf0) == 0xe0) {
    extra = 2;
    cp = c & 0x0f;
  } else if ((c & 0xf8) == 0xf0) {
    extra = 3;
    cp = c & 0x07;
  } else {
    return {0, 0};
  }
  if (i + extra >= text.size()) return {0, 0};
  for (size_t k = 1; k <= extra; ++k) {
    const unsigned char cc = static_cast<unsigned char>(text[i + k]);
    if ((cc & 0xc0) != 0x80) return {0, 0};
    cp = (cp << 6) | (cc & 0x3f);
  }
  if ((extra == 1 && cp < 0x80) || (extra == 2 && cp < 0x800) || (extra == 3 && cp < 0x10000) ||
      (cp >= 0xd800 && cp <= 0xdfff) || cp > 0x10ffff) {
    return {0, 0};
  }
  return {cp, extra + 1};
}

// What kind of unreadable character `cp` is ("" for a readable one): C0 and C1 controls,
// and the format characters that change how the text around them is shown without
// showing themselves: bidirectional controls (which can make "gpj.exe" read "exe.jpg"),
// zero-width and invisible characters, line and paragraph separators, tags.
const char* UnreadableKind(uint32_t cp) {
  if (cp < 0x20 || (cp >= 0x7f && cp < 0xa0)) return "a control character";
  if ((cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2066 && cp <= 0x2069) || cp == 0x200e ||
      cp == 0x200f || cp == 0x061c) {
    return "a bidirectional control";
  }
  if ((cp >= 0x200b && cp <= 0x200d) || (cp >= 0x2060 && cp <= 0x2064) || cp == 0xfeff ||
      cp == 0x00ad || cp == 0x034f || cp == 0x180e || (cp >= 0xfff9 && cp <= 0xfffb) ||
      (cp >= 0xe0000 && cp <= 0xe007f)) {
    return "an invisible character";
  }
  if (cp == 0x2028 || cp == 0x2029) return "a line or paragraph separator";
  return "";
}

}  // namespace

std::string QuotedForMessage(const std::string& text, size_t max_chars) {
  std::string out = "'";
  size_t shown = 0, i = 0;
  while (i < text.size() && shown < max_chars) {
    const auto [cp, length] = DecodeUtf8(text, i);
    char buf[16];
    if (length == 0) {  // not UTF-8: the byte
      std::snprintf(buf, sizeof(buf), "\\x%02x", static_cast<unsigned char>(text[i]));
      out += buf;
      i += 1;
    } else if (*UnreadableKind(cp) != '\0') {
      if (cp < 0x80) {
        std::snprintf(buf, sizeof(buf), "\\x%02x", static_cast<unsigned>(cp));
      } else {
        std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(cp));
      }
      out += buf;
      i += length;
    } else {
      out.append(text, i, length);
      i += length;
    }
    ++shown;
  }
  out += "'";
  if (i < text.size()) {
    out.insert(out.size() - 1, "...");
    out += " (" + std::to_string(text.size()) + " characters)";
  }
  return out;
}

std::string UnreadableCharacter(const std::string& text) {
  size_t i = 0;
  while (i < text.size()) {
    const auto [cp, length] = DecodeUtf8(text, i);
    if (length == 0) return "invalid UTF-8 at byte " + std::to_string(i);
    const char* kind = UnreadableKind(cp);
    if (*kind != '\0') {
      char code[16];
      std::snprintf(code, sizeof(code), "U+%04X", static_cast<unsigned>(cp));
      return std::string(kind) + " (" + code + ") at byte " + std::to_string(i);
    }
    i += length;
  }
  return "";
}

bool IsPrintableUtf8(const std::string& text) { return UnreadableCharacter(text).empty(); }

}  // namespace bsf_vpr
