#include "xml_lite.h"

#include <cctype>
#include <cstring>

#include "mmba/core/error.h"

namespace mmba::io::xml {

const std::string* Element::Attribute(const std::string& attribute) const {
  for (const auto& [key, value] : attributes) {
    if (key == attribute) return &value;
  }
  return nullptr;
}

namespace {

class Parser {
 public:
  Parser(const std::string& text, const std::string& file) : s_(text), file_(file) {}

  std::unique_ptr<Element> Document() {
    std::unique_ptr<Element> root;
    while (true) {
      SkipSpace();
      if (pos_ >= s_.size()) break;
      if (StartsWith("<?")) {
        SkipPast("?>", "processing instruction");
      } else if (StartsWith("<!--")) {
        SkipPast("-->", "comment");
      } else if (StartsWith("<!DOCTYPE")) {
        SkipPast(">", "DOCTYPE");
      } else if (StartsWith("<")) {
        if (root) Fail("document", "a second root element", "one root element");
        root = ParseElement();
      } else {
        Fail("document", Snippet(), "an element");
      }
    }
    if (!root) Fail("document", "no element", "a root element");
    return root;
  }

 private:
  [[noreturn]] void Fail(const std::string& field, const std::string& found,
                         const std::string& expected) const {
    throw InputError(file_, line_, field, found, expected);
  }

  std::string Snippet() const {
    std::string out = s_.substr(pos_, 20);
    for (char& c : out) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    return out;
  }

  bool StartsWith(const char* prefix) const {
    return s_.compare(pos_, std::strlen(prefix), prefix) == 0;
  }

  void Advance(size_t n) {
    for (size_t i = 0; i < n && pos_ < s_.size(); ++i) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  void SkipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) Advance(1);
  }

  void SkipPast(const char* end, const char* what) {
    const size_t found = s_.find(end, pos_);
    if (found == std::string::npos) Fail(what, "end of file", std::string("'") + end + "'");
    Advance(found + std::strlen(end) - pos_);
  }

  std::string Name() {
    const size_t start = pos_;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
          c == '.' || static_cast<unsigned char>(c) >= 0x80) {
        ++pos_;
      } else {
        break;
      }
    }
    if (pos_ == start) Fail("name", Snippet(), "an XML name");
    return s_.substr(start, pos_ - start);
  }

  std::string Decode(const std::string& raw) {
    std::string out;
    for (size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] != '&') {
        out += raw[i];
        continue;
      }
      const size_t semi = raw.find(';', i);
      if (semi == std::string::npos) Fail("entity", raw.substr(i, 10), "an entity ending in ';'");
      const std::string entity = raw.substr(i + 1, semi - i - 1);
      if (entity == "lt") out += '<';
      else if (entity == "gt") out += '>';
      else if (entity == "amp") out += '&';
      else if (entity == "quot") out += '"';
      else if (entity == "apos") out += '\'';
      else if (!entity.empty() && entity[0] == '#') {
        long code = 0;
        try {
          code = entity.size() > 1 && (entity[1] == 'x' || entity[1] == 'X')
                     ? std::stol(entity.substr(2), nullptr, 16)
                     : std::stol(entity.substr(1));
        } catch (...) {
          Fail("entity", "&" + entity + ";", "a numeric character reference");
        }
        if (code < 0x80) {
          out += static_cast<char>(code);
        } else if (code < 0x800) {
          out += static_cast<char>(0xC0 | (code >> 6));
          out += static_cast<char>(0x80 | (code & 0x3F));
        } else {
          out += static_cast<char>(0xE0 | (code >> 12));
          out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
          out += static_cast<char>(0x80 | (code & 0x3F));
        }
      } else {
        Fail("entity", "&" + entity + ";", "one of &lt; &gt; &amp; &quot; &apos; &#N;");
      }
      i = semi;
    }
    return out;
  }

  std::unique_ptr<Element> ParseElement() {
    auto element = std::make_unique<Element>();
    element->line = line_;
    Advance(1);  // '<'
    element->name = Name();
    while (true) {
      SkipSpace();
      if (pos_ >= s_.size()) Fail(element->name, "end of file", "'>'");
      if (StartsWith("/>")) {
        Advance(2);
        return element;
      }
      if (s_[pos_] == '>') {
        Advance(1);
        break;
      }
      const int attribute_line = line_;
      const std::string key = Name();
      SkipSpace();
      if (pos_ >= s_.size() || s_[pos_] != '=') {
        Fail(element->name + "@" + key, Snippet(), "'=' and a quoted value");
      }
      Advance(1);
      SkipSpace();
      if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\'')) {
        Fail(element->name + "@" + key, Snippet(), "a quoted value");
      }
      const char quote = s_[pos_];
      Advance(1);
      const size_t end = s_.find(quote, pos_);
      if (end == std::string::npos) Fail(element->name + "@" + key, "end of file", "a closing quote");
      const std::string raw = s_.substr(pos_, end - pos_);
      Advance(end + 1 - pos_);
      if (element->Attribute(key) != nullptr) {
        throw InputError(file_, attribute_line, element->name + "@" + key, "a repeated attribute",
                         "each attribute once");
      }
      element->attributes.emplace_back(key, Decode(raw));
    }
    // Content.
    while (true) {
      if (pos_ >= s_.size()) Fail(element->name, "end of file", "</" + element->name + ">");
      if (StartsWith("</")) {
        Advance(2);
        const std::string name = Name();
        if (name != element->name) Fail("</" + name + ">", name, "</" + element->name + ">");
        SkipSpace();
        if (pos_ >= s_.size() || s_[pos_] != '>') Fail("</" + name + ">", Snippet(), "'>'");
        Advance(1);
        return element;
      }
      if (StartsWith("<!--")) {
        SkipPast("-->", "comment");
      } else if (StartsWith("<![CDATA[")) {
        Advance(9);
        const size_t end = s_.find("]]>", pos_);
        if (end == std::string::npos) Fail("CDATA", "end of file", "']]>'");
        element->text += s_.substr(pos_, end - pos_);
        Advance(end + 3 - pos_);
      } else if (StartsWith("<?")) {
        SkipPast("?>", "processing instruction");
      } else if (s_[pos_] == '<') {
        element->children.push_back(ParseElement());
      } else {
        const size_t end = s_.find('<', pos_);
        const size_t stop = end == std::string::npos ? s_.size() : end;
        element->text += Decode(s_.substr(pos_, stop - pos_));
        Advance(stop - pos_);
      }
    }
  }

  const std::string& s_;
  const std::string& file_;
  size_t pos_ = 0;
  int line_ = 1;
};

}  // namespace

std::unique_ptr<Element> Parse(const std::string& text, const std::string& file) {
  return Parser(text, file).Document();
}

}  // namespace mmba::io::xml
