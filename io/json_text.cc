#include "io/json_text.hh"

#include "io/scene_reader.hh"

#include <vector>

namespace rodmesh {
namespace {

using json = nlohmann::json;

// 1-based line and column of byte `offset` of `text`.
std::string lineColumn(const std::string& text, std::size_t offset) {
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

// Rejects nesting deeper than kMaxJsonDepth before the parser sees the text.
// Brackets inside strings do not count; the text need not be valid JSON (the
// parser reports other problems).
void checkDepth(const std::string& text, const std::string& path) {
  int depth = 0;
  bool inString = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (inString) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
      continue;
    }
    if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw InputError(path + ": " + lineColumn(text, i) + ": arrays and objects nested deeper than " +
                         std::to_string(kMaxJsonDepth) + " levels (a scene needs 5); not a scene file");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

// Builds the value like nlohmann's own DOM parser and keeps the key path of
// the value being parsed, so that an error can say where it is.
class PathSax : public nlohmann::json_sax<json> {
 public:
  explicit PathSax(json& root) : root_(root) {}

  bool null() override { return place(json(nullptr)) != nullptr; }
  bool boolean(bool v) override { return place(json(v)) != nullptr; }
  bool number_integer(number_integer_t v) override { return place(json(v)) != nullptr; }
  bool number_unsigned(number_unsigned_t v) override { return place(json(v)) != nullptr; }
  bool number_float(number_float_t v, const string_t&) override { return place(json(v)) != nullptr; }
  bool string(string_t& v) override { return place(json(std::move(v))) != nullptr; }
  bool binary(binary_t& v) override { return place(json::binary(std::move(v))) != nullptr; }
  bool start_object(std::size_t) override { return open(json::object(), false); }
  bool key(string_t& k) override {
    Frame& f = frames_.back();
    if (f.value->contains(k)) {
      // A second value for a key would silently replace the first.
      f.key = k;
      f.hasKey = true;
      duplicate_ = path();
      return false;
    }
    f.key = k;
    f.hasKey = true;
    return true;
  }
  bool end_object() override { return close(); }
  bool start_array(std::size_t) override { return open(json::array(), true); }
  bool end_array() override { return close(); }
  bool parse_error(std::size_t position, const std::string& token, const nlohmann::detail::exception& ex) override {
    failed_ = true;
    position_ = position;
    token_ = token;
    id_ = ex.id;
    what_ = ex.what();
    return false;
  }

  bool failed() const { return failed_; }
  // The key path of a key given twice in one object ("" if none).
  const std::string& duplicate() const { return duplicate_; }
  std::size_t position() const { return position_; }
  const std::string& token() const { return token_; }
  int id() const { return id_; }
  const std::string& what() const { return what_; }

  // Key path of the value the parser is reading ("" at the top level).
  std::string path() const {
    std::string p;
    for (std::size_t i = 0; i < frames_.size(); ++i) {
      const Frame& f = frames_[i];
      const bool innermost = i + 1 == frames_.size();
      if (f.isArray) {
        // Outer arrays: the element being read; the innermost: the next one.
        const long index = innermost ? f.index + 1 : f.index;
        p += "[" + std::to_string(index < 0 ? 0 : index) + "]";
      } else if (f.hasKey) {
        p = withKey(p, f.key);
      }
    }
    return p;
  }

 private:
  struct Frame {
    json* value;
    bool isArray;
    long index = -1;  // arrays: index of the last element placed
    std::string key;  // objects: the last key read
    bool hasKey = false;
  };

  json* place(json&& v) {
    if (frames_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    Frame& f = frames_.back();
    if (f.isArray) {
      ++f.index;
      f.value->push_back(std::move(v));
      return &f.value->back();
    }
    json& slot = (*f.value)[f.key];
    slot = std::move(v);
    return &slot;
  }
  bool open(json&& container, bool isArray) {
    json* j = place(std::move(container));
    frames_.push_back(Frame{j, isArray, -1, std::string(), false});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return true;
  }

  json& root_;
  std::vector<Frame> frames_;
  bool failed_ = false;
  std::size_t position_ = 0;
  std::string token_, what_, duplicate_;
  int id_ = 0;
};

// nlohmann's message without its "[json.exception...] parse error at line
// L, column C: " prefix (we give the line and column ourselves).
std::string parserMessage(const std::string& what) {
  const std::size_t col = what.find("column ");
  if (col != std::string::npos) {
    const std::size_t colon = what.find(": ", col);
    if (colon != std::string::npos) return what.substr(colon + 2);
  }
  const std::size_t bracket = what.find("] ");
  return bracket == std::string::npos ? what : what.substr(bracket + 2);
}

void appendShort(const json& j, std::string& out, std::size_t limit, bool& cut) {
  if (out.size() >= limit) {
    cut = true;
    return;
  }
  switch (j.type()) {
    case json::value_t::array: {
      out += '[';
      bool first = true;
      for (const json& e : j) {
        if (out.size() >= limit) {
          cut = true;
          break;
        }
        if (!first) out += ',';
        first = false;
        appendShort(e, out, limit, cut);
      }
      out += ']';
      break;
    }
    case json::value_t::object: {
      out += '{';
      bool first = true;
      for (auto it = j.begin(); it != j.end(); ++it) {
        if (out.size() >= limit) {
          cut = true;
          break;
        }
        if (!first) out += ',';
        first = false;
        appendShort(json(it.key().substr(0, limit)), out, limit, cut);
        out += ':';
        appendShort(it.value(), out, limit, cut);
      }
      out += '}';
      break;
    }
    case json::value_t::string: {
      const std::string& s = j.get_ref<const std::string&>();
      if (s.size() > limit) cut = true;
      out += json(s.substr(0, limit)).dump(-1, ' ', false, json::error_handler_t::replace);
      break;
    }
    default:
      out += j.dump();
  }
}

}  // namespace

std::string shortJson(const json& j, std::size_t maxChars) {
  std::string out;
  bool cut = false;
  appendShort(j, out, maxChars, cut);
  if (cut || out.size() > maxChars) out = out.substr(0, maxChars > 3 ? maxChars - 3 : 0) + "...";
  return out;
}

std::string quotedText(const std::string& text, std::size_t maxChars) {
  return shortJson(json(text.substr(0, maxChars + 1)), maxChars);
}

std::string withKey(const std::string& path, const std::string& key) {
  bool plain = !key.empty() && key.size() <= 40;
  for (char c : key)
    plain = plain && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_');
  if (plain) return path.empty() ? key : path + "." + key;
  return path + "[" + quotedText(key, 40) + "]";
}

json parseJsonText(const std::string& text, const std::string& path) {
  checkDepth(text, path);
  json doc;
  PathSax sax(doc);
  const bool ok = json::sax_parse(text, &sax);
  if (ok && !sax.failed()) return doc;
  if (!sax.duplicate().empty())
    throw InputError(path + ": " + printableText(sax.duplicate(), 240) +
                     ": key given twice in the same object (the second value would replace the first)");
  const std::string where = sax.path();
  if (sax.id() == 406) {
    // A number beyond the double range: name it and where it is.
    const std::size_t start = sax.position() >= sax.token().size() ? sax.position() - sax.token().size() : 0;
    throw InputError(path + ": " + (where.empty() ? std::string("<root>") : where) + ": number " +
                     printableText(sax.token(), 40) + " is out of range (beyond +-1.8e308) (" +
                     lineColumn(text, start) + ")");
  }
  // The parser reports the position after the character it stopped at.
  std::string what = parserMessage(sax.what());
  if (what.size() > 240) what = what.substr(0, 237) + "...";
  throw InputError(path + ": not valid JSON (" + lineColumn(text, sax.position() > 0 ? sax.position() - 1 : 0) +
                   (where.empty() ? std::string() : ", in " + where) + "): " + printableText(what, 240));
}

}  // namespace rodmesh
