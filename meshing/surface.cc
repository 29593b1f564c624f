#include "meshing/surface.hh"

#include "io/scene_reader.hh"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_map>

namespace rodmesh::meshing {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw InputError(path + ": " + what);
}

std::string lowerExtension(const std::string& path) {
  auto dot = path.find_last_of('.');
  auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

std::string readAll(const std::string& path) { return readInputFile(path, "surface file"); }

// ---------------------------------------------------------------- numbers
// Every number in a surface file is parsed strictly: the whole token must be
// the number, reals must be finite and integers must fit, so that garbage
// such as "2.5", "3abc", "1e999" or "4294967299" is reported with its file,
// line and text instead of being truncated, wrapped or turned into inf.

constexpr long long kMaxCount = std::numeric_limits<int>::max();  // vertices, faces, entries

// A token for a message: quoted, at most 40 characters, other bytes escaped.
std::string quoted(const std::string& t) {
  std::string out = "'";
  const std::size_t n = std::min<std::size_t>(t.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    if (c >= 0x20 && c < 0x7f) {
      out.push_back(static_cast<char>(c));
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  if (t.size() > n) out += "...";
  return out + "'";
}

std::string formatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string formatShort(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

enum class NumberStatus { Ok, Syntax, Overflow, NonFinite, TooLarge };

// The whole token as a real number (C locale syntax). Overflow (1e999) and
// inf/nan are reported as such; underflow to zero or a subnormal is accepted.
NumberStatus parseReal(const std::string& t, double& out) {
  if (t.empty() || std::isspace(static_cast<unsigned char>(t[0]))) return NumberStatus::Syntax;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (end != t.c_str() + t.size()) return NumberStatus::Syntax;  // also catches embedded NUL bytes
  if (errno == ERANGE && std::isinf(v)) return NumberStatus::Overflow;
  if (!std::isfinite(v)) return NumberStatus::NonFinite;
  out = v;
  return NumberStatus::Ok;
}

// The whole token as a decimal integer: an optional sign and digits only.
NumberStatus parseInteger(const std::string& t, long long& out) {
  std::size_t i = 0;
  const bool negative = !t.empty() && t[0] == '-';
  if (!t.empty() && (t[0] == '-' || t[0] == '+')) i = 1;
  if (i == t.size()) return NumberStatus::Syntax;
  constexpr unsigned long long kMax = std::numeric_limits<long long>::max();
  unsigned long long magnitude = 0;
  bool overflow = false;
  for (; i < t.size(); ++i) {  // bounded by the token length; scans on to report syntax first
    if (t[i] < '0' || t[i] > '9') return NumberStatus::Syntax;
    const unsigned d = static_cast<unsigned>(t[i] - '0');
    if (overflow || magnitude > (kMax - d) / 10)
      overflow = true;
    else
      magnitude = magnitude * 10 + d;
  }
  if (overflow) return NumberStatus::Overflow;
  out = negative ? -static_cast<long long>(magnitude) : static_cast<long long>(magnitude);
  return NumberStatus::Ok;
}

// "<what> '<token>' is not a number", "... overflows", "... is not finite".
std::string realProblem(const std::string& what, const std::string& token, NumberStatus st) {
  switch (st) {
    case NumberStatus::Syntax:
      return what + " " + quoted(token) + " is not a number";
    case NumberStatus::Overflow:
      return what + " " + quoted(token) + " overflows (beyond +-1.8e308)";
    case NumberStatus::NonFinite:
      return what + " " + quoted(token) + " is not finite";
    case NumberStatus::TooLarge:
      return what + " " + quoted(token) + " is too large (coordinates must lie within +-" +
             formatShort(kMaxSurfaceCoordinate) + ")";
    case NumberStatus::Ok:
      break;
  }
  return what + " " + quoted(token);
}

// A vertex coordinate: a finite number within +-kMaxSurfaceCoordinate.
NumberStatus parseCoordinate(const std::string& t, double& out) {
  const NumberStatus st = parseReal(t, out);
  if (st == NumberStatus::Ok && !(std::abs(out) <= kMaxSurfaceCoordinate)) return NumberStatus::TooLarge;
  return st;
}

std::string integerProblem(const std::string& what, const std::string& token, NumberStatus st) {
  if (st == NumberStatus::Overflow) return what + " " + quoted(token) + " is too large";
  return what + " " + quoted(token) + " is not an integer";
}

// "the file has 4 vertices (indices 0 to 3)" for 0-based formats.
std::string vertexRange(long long nv) {
  if (nv == 0) return "the file has no vertices";
  return "the file has " + std::to_string(nv) + (nv == 1 ? " vertex" : " vertices") + " (indices 0 to " +
         std::to_string(nv - 1) + ")";
}

// Whitespace-separated tokens of a text with their 1-based line numbers;
// optionally '#' starts a comment that runs to the end of the line.
class Tokens {
 public:
  Tokens(const std::string& text, std::size_t pos, int firstLine, bool hashComments)
      : text_(text), pos_(pos), line_(firstLine), hashComments_(hashComments) {}

  // The next token, or false at the end of the text.
  bool next(std::string& tok) {
    skipSpace(true);
    if (pos_ >= text_.size()) return false;
    tokenLine_ = line_;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !isSpace(text_[pos_]) && !(hashComments_ && text_[pos_] == '#')) ++pos_;
    tok.assign(text_, start, pos_ - start);
    return true;
  }
  // True when another token follows on the line of the last token.
  bool moreOnLine() {
    skipSpace(false);
    return pos_ < text_.size() && text_[pos_] != '\n';
  }
  // Drops the rest of the current line.
  void skipLine() {
    const std::size_t e = text_.find('\n', pos_);
    pos_ = e == std::string::npos ? text_.size() : e;  // the newline itself is counted by skipSpace
  }
  int line() const { return tokenLine_; }

 private:
  static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }
  void skipSpace(bool newlines) {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        if (!newlines) return;
        ++line_;
        ++pos_;
      } else if (isSpace(c)) {
        ++pos_;
      } else if (hashComments_ && c == '#') {
        const std::size_t e = text_.find('\n', pos_);
        pos_ = e == std::string::npos ? text_.size() : e;
      } else {
        return;
      }
    }
  }

  const std::string& text_;
  std::size_t pos_;
  int line_, tokenLine_ = 0;
  bool hashComments_;
};

const char* const kAxis[3] = {"x", "y", "z"};

// ---------------------------------------------------------------- OBJ
PolygonSoup parseObj(const std::string& text, const std::string& path) {
  PolygonSoup soup;
  // A positive index may refer to a vertex defined further down the file; such
  // forward references are checked against the final vertex count.
  struct Forward {
    long long index;
    int line;
    std::string token;
  };
  std::vector<Forward> forward;
  std::istringstream in(text);
  std::string line;
  int lineNo = 0;
  auto failLine = [&](const std::string& what) { fail(path, "line " + std::to_string(lineNo) + ": " + what); };
  while (std::getline(in, line)) {  // bounded by the file
    ++lineNo;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag) || tag[0] == '#') continue;
    if (tag == "v") {
      double c[3];
      for (int k = 0; k < 3; ++k) {
        std::string tok;
        if (!(ls >> tok)) failLine("vertex needs three coordinates x y z: " + quoted(line));
        const NumberStatus st = parseCoordinate(tok, c[k]);
        if (st != NumberStatus::Ok) failLine(realProblem(std::string("vertex coordinate ") + kAxis[k], tok, st));
      }
      if (static_cast<long long>(soup.vertices.size()) >= kMaxCount) failLine("too many vertices");
      soup.vertices.emplace_back(c[0], c[1], c[2]);
    } else if (tag == "f") {
      std::vector<int> face;
      std::string tok;
      const long long n = static_cast<long long>(soup.vertices.size());
      while (ls >> tok) {  // bounded by the line
        // v, v/vt, v//vn or v/vt/vn: the vertex index is the part before '/'.
        long long v = 0;
        const NumberStatus st = parseInteger(tok.substr(0, tok.find('/')), v);
        if (st != NumberStatus::Ok) failLine(integerProblem("face index", tok, st));
        if (v == 0)
          failLine("face index " + quoted(tok) + " is invalid: OBJ vertex indices start at 1 (or -1 from the end)");
        if (v < 0) {
          if (-v > n)
            failLine("face index " + quoted(tok) + " counts back " + std::to_string(-v) + " vertices, but only " +
                     std::to_string(n) + " are defined before this line");
          face.push_back(static_cast<int>(n + v));
        } else {
          if (v > n) forward.push_back({v, lineNo, tok});
          face.push_back(v > kMaxCount ? -1 : static_cast<int>(v - 1));
        }
      }
      if (static_cast<long long>(soup.faces.size()) >= kMaxCount) failLine("too many faces");
      soup.faces.push_back(std::move(face));
    }
    // vn, vt, g, o, s, usemtl, mtllib, l, ...: ignored.
  }
  const long long nv = static_cast<long long>(soup.vertices.size());
  for (const Forward& f : forward)
    if (f.index > nv)
      fail(path, "line " + std::to_string(f.line) + ": face index " + quoted(f.token) + " is out of range: " +
                     (nv == 0 ? std::string("the file has no vertices")
                              : "the file has " + std::to_string(nv) + " vertices (OBJ indices 1 to " +
                                    std::to_string(nv) + ", or -1 to -" + std::to_string(nv) + " from the end)"));
  return soup;
}

// ---------------------------------------------------------------- OFF
PolygonSoup parseOff(const std::string& text, const std::string& path) {
  Tokens tk(text, 0, 1, true);
  auto failLine = [&](const std::string& what) { fail(path, "line " + std::to_string(tk.line()) + ": " + what); };
  std::string head;
  if (!tk.next(head)) fail(path, "not an OFF file (it is empty)");
  if (head.size() < 3 || head.substr(head.size() - 3) != "OFF")
    fail(path, "not an OFF file (first token " + quoted(head) + ", expected 'OFF')");
  if (head != "OFF") fail(path, "OFF variant " + quoted(head) + " is not supported (plain OFF only)");
  long long counts[3] = {0, 0, 0};
  const char* const names[3] = {"vertex count", "face count", "edge count"};
  for (int k = 0; k < 3; ++k) {
    std::string tok;
    if (!tk.next(tok))
      fail(path, std::string("the OFF header ends before its ") + names[k] +
                     " (expected 'OFF', then the vertex, face and edge counts)");
    const NumberStatus st = parseInteger(tok, counts[k]);
    if (st != NumberStatus::Ok) failLine(integerProblem(std::string("OFF header ") + names[k], tok, st));
    if (counts[k] < 0) failLine(std::string("OFF header ") + names[k] + " " + quoted(tok) + " is negative");
  }
  const long long nv = counts[0], nf = counts[1];
  // Each vertex takes at least 6 bytes ("0 0 0\n"), each face at least 2 ("0\n").
  if (nv > kMaxCount || nf > kMaxCount || 6.0 * nv + 2.0 * nf > static_cast<double>(text.size()) + 2)
    failLine("the OFF header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
             " faces, more than the file's " + std::to_string(text.size()) + " bytes can hold");
  PolygonSoup soup;
  soup.vertices.reserve(static_cast<std::size_t>(nv));
  for (long long i = 0; i < nv; ++i) {
    double c[3];
    for (int k = 0; k < 3; ++k) {
      std::string tok;
      if (!tk.next(tok))
        fail(path, "vertex " + std::to_string(i) +
                       ": the file ends before its three coordinates (the header declares " + std::to_string(nv) +
                       " vertices)");
      const NumberStatus st = parseCoordinate(tok, c[k]);
      if (st != NumberStatus::Ok)
        failLine("vertex " + std::to_string(i) + ": " + realProblem(std::string("coordinate ") + kAxis[k], tok, st));
    }
    soup.vertices.emplace_back(c[0], c[1], c[2]);
  }
  // Faces: one per line, "n i1 ... in" and optional colour values after that.
  soup.faces.reserve(static_cast<std::size_t>(nf));
  for (long long f = 0; f < nf; ++f) {
    const std::string fn = "face " + std::to_string(f) + ": ";
    tk.skipLine();
    std::string tok;
    if (!tk.next(tok)) fail(path, fn + "the file ends early (the header declares " + std::to_string(nf) + " faces)");
    long long n = 0;
    NumberStatus st = parseInteger(tok, n);
    if (st != NumberStatus::Ok) failLine(fn + integerProblem("corner count", tok, st));
    if (n < 0) failLine(fn + "corner count " + quoted(tok) + " is negative");
    std::vector<int> face;
    for (long long k = 0; k < n; ++k) {  // bounded by the tokens on the line
      if (!tk.moreOnLine() || !tk.next(tok))
        failLine(fn + "the line ends after " + std::to_string(k) + " of its " + std::to_string(n) + " vertex indices");
      long long v = 0;
      st = parseInteger(tok, v);
      if (st != NumberStatus::Ok) failLine(fn + integerProblem("vertex index", tok, st));
      if (v < 0 || v >= nv) failLine(fn + "vertex index " + quoted(tok) + " is out of range: " + vertexRange(nv));
      face.push_back(static_cast<int>(v));
    }
    soup.faces.push_back(std::move(face));
  }
  return soup;
}

// ---------------------------------------------------------------- PLY
enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

PlyType plyType(const std::string& t, const std::string& path, int line) {
  if (t == "char" || t == "int8") return PlyType::I8;
  if (t == "uchar" || t == "uint8") return PlyType::U8;
  if (t == "short" || t == "int16") return PlyType::I16;
  if (t == "ushort" || t == "uint16") return PlyType::U16;
  if (t == "int" || t == "int32") return PlyType::I32;
  if (t == "uint" || t == "uint32") return PlyType::U32;
  if (t == "float" || t == "float32") return PlyType::F32;
  if (t == "double" || t == "float64") return PlyType::F64;
  fail(path, "line " + std::to_string(line) + ": unknown PLY property type " + quoted(t));
}

const char* plyTypeName(PlyType t) {
  switch (t) {
    case PlyType::I8:
      return "char";
    case PlyType::U8:
      return "uchar";
    case PlyType::I16:
      return "short";
    case PlyType::U16:
      return "ushort";
    case PlyType::I32:
      return "int";
    case PlyType::U32:
      return "uint";
    case PlyType::F32:
      return "float";
    case PlyType::F64:
      return "double";
  }
  return "?";
}

int plySize(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 0;
}

bool plyIsInteger(PlyType t) { return t != PlyType::F32 && t != PlyType::F64; }

// Range of an integer PLY type.
void plyIntegerRange(PlyType t, long long& lo, long long& hi) {
  switch (t) {
    case PlyType::I8:
      lo = -128, hi = 127;
      return;
    case PlyType::U8:
      lo = 0, hi = 255;
      return;
    case PlyType::I16:
      lo = -32768, hi = 32767;
      return;
    case PlyType::U16:
      lo = 0, hi = 65535;
      return;
    case PlyType::I32:
      lo = -2147483648LL, hi = 2147483647LL;
      return;
    default:
      lo = 0, hi = 4294967295LL;
      return;
  }
}

struct PlyProperty {
  std::string name;
  bool isList = false;
  PlyType countType = PlyType::U8, type = PlyType::F32;
};
struct PlyElement {
  std::string name;
  long long count = 0;
  int line = 0;  // header line, for messages
  std::vector<PlyProperty> props;
};

// Reads the values of the data section, ASCII (token by token, strictly, with
// line numbers) or binary. Errors name the line (ASCII) or the element entry
// (binary) and the offending value.
class PlyValueReader {
 public:
  PlyValueReader(const std::string& data, std::size_t pos, int firstLine, int format, const std::string& path)
      : data_(data), pos_(pos), format_(format), path_(path), tokens_(data, pos, firstLine, false) {}

  // "line 12: face 3" (ASCII) or "face 3 (binary data)": where the last value was read.
  std::string where(const PlyElement& e, long long i) const {
    const std::string entry = e.name + " " + std::to_string(i);
    if (format_ == 0) return "line " + std::to_string(tokens_.line()) + ": " + entry;
    return entry + " (binary data)";
  }
  [[noreturn]] void failAt(const PlyElement& e, long long i, const std::string& what) const {
    fail(path_, where(e, i) + ": " + what);
  }
  // The last value as written: the ASCII token, or the decoded binary number.
  const std::string& text() const { return text_; }

  double read(PlyType t, const PlyElement& e, long long i, const std::string& prop) {
    if (format_ == 0) return readAscii(t, e, i, prop);
    const int n = plySize(t);
    if (pos_ + n > data_.size())
      fail(path_, e.name + " " + std::to_string(i) + ": the binary data ends early (property '" + prop + "')");
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    if (format_ == 2) std::reverse(b, b + n);  // big endian -> little (x86 host)
    double v = 0;
    switch (t) {
      case PlyType::I8: {
        int8_t x;
        std::memcpy(&x, b, 1);
        v = x;
        break;
      }
      case PlyType::U8: {
        uint8_t x;
        std::memcpy(&x, b, 1);
        v = x;
        break;
      }
      case PlyType::I16: {
        int16_t x;
        std::memcpy(&x, b, 2);
        v = x;
        break;
      }
      case PlyType::U16: {
        uint16_t x;
        std::memcpy(&x, b, 2);
        v = x;
        break;
      }
      case PlyType::I32: {
        int32_t x;
        std::memcpy(&x, b, 4);
        v = x;
        break;
      }
      case PlyType::U32: {
        uint32_t x;
        std::memcpy(&x, b, 4);
        v = x;
        break;
      }
      case PlyType::F32: {
        float x;
        std::memcpy(&x, b, 4);
        v = x;
        break;
      }
      case PlyType::F64: {
        double x;
        std::memcpy(&x, b, 8);
        v = x;
        break;
      }
    }
    text_ = formatNumber(v);
    return v;
  }

 private:
  double readAscii(PlyType t, const PlyElement& e, long long i, const std::string& prop) {
    if (!tokens_.next(text_))
      fail(path_, e.name + " " + std::to_string(i) + ": the data ends early (property '" + prop + "')");
    const std::string what = "property '" + prop + "' value";
    if (plyIsInteger(t)) {
      long long v = 0;
      const NumberStatus st = parseInteger(text_, v);
      if (st != NumberStatus::Ok) failAt(e, i, integerProblem(what, text_, st) + " (PLY type " + plyTypeName(t) + ")");
      long long lo = 0, hi = 0;
      plyIntegerRange(t, lo, hi);
      if (v < lo || v > hi)
        failAt(e, i,
               what + " " + quoted(text_) + " does not fit PLY type " + plyTypeName(t) + " (" + std::to_string(lo) +
                   " to " + std::to_string(hi) + ")");
      return static_cast<double>(v);
    }
    double v = 0;
    const NumberStatus st = parseReal(text_, v);
    if (st == NumberStatus::NonFinite) return std::strtod(text_.c_str(), nullptr);  // inf/nan: the caller decides
    if (st != NumberStatus::Ok) failAt(e, i, realProblem(what, text_, st));
    return v;
  }

  const std::string& data_;
  std::size_t pos_;
  int format_;  // 0 ascii, 1 little endian, 2 big endian
  std::string path_;
  Tokens tokens_;
  std::string text_;
};

PolygonSoup parsePly(const std::string& data, const std::string& path) {
  std::size_t pos = 0;
  int lineNo = 0;
  auto nextLine = [&](std::string& line) {
    if (pos >= data.size()) return false;
    std::size_t e = data.find('\n', pos);
    if (e == std::string::npos) e = data.size();
    line = data.substr(pos, e - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(e + 1, data.size());
    ++lineNo;
    return true;
  };
  auto failLine = [&](const std::string& what) { fail(path, "line " + std::to_string(lineNo) + ": " + what); };
  std::string line;
  if (!nextLine(line) || line != "ply") fail(path, "not a PLY file (missing 'ply' magic line)");
  int format = -1;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (nextLine(line)) {  // bounded by the file
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string f;
      ls >> f;
      if (f == "ascii") format = 0;
      else if (f == "binary_little_endian") format = 1;
      else if (f == "binary_big_endian") format = 2;
      else
        failLine("unknown PLY format " + quoted(f));
    } else if (kw == "element") {
      PlyElement e;
      e.line = lineNo;
      std::string countTok;
      if (!(ls >> e.name >> countTok)) failLine("PLY element line needs a name and a count: " + quoted(line));
      const NumberStatus st = parseInteger(countTok, e.count);
      if (st != NumberStatus::Ok) failLine(integerProblem("PLY element '" + e.name + "' count", countTok, st));
      if (e.count < 0) failLine("PLY element '" + e.name + "' count " + quoted(countTok) + " is negative");
      if (e.count > kMaxCount)
        failLine("PLY element '" + e.name + "' declares " + countTok + " entries; at most " +
                 std::to_string(kMaxCount) + " are supported");
      elements.push_back(e);
    } else if (kw == "property") {
      if (elements.empty()) failLine("PLY property before any element");
      PlyProperty p;
      std::string t;
      ls >> t;
      if (t == "list") {
        std::string ct, it;
        ls >> ct >> it >> p.name;
        p.isList = true;
        p.countType = plyType(ct, path, lineNo);
        p.type = plyType(it, path, lineNo);
        if (!plyIsInteger(p.countType)) failLine("PLY list count type " + quoted(ct) + " is not an integer type");
      } else {
        p.type = plyType(t, path, lineNo);
        ls >> p.name;
      }
      if (p.name.empty()) failLine("PLY property without a name: " + quoted(line));
      elements.back().props.push_back(p);
    } else if (kw == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended) fail(path, "PLY header has no 'end_header'");
  if (format < 0) fail(path, "PLY header has no 'format' line");

  // The declared counts must fit in the data: an entry takes at least 2 bytes
  // per value in ASCII ("0 ") and the size of its scalars and list counts in
  // binary. This rejects absurd counts before any work is done.
  const double available = static_cast<double>(data.size() - pos) + (format == 0 ? 1 : 0);
  double needed = 0;
  long long declaredVertices = 0;
  for (const PlyElement& e : elements) {
    double perEntry = 0;
    for (const PlyProperty& p : e.props) perEntry += format == 0 ? 2 : plySize(p.isList ? p.countType : p.type);
    needed += perEntry * static_cast<double>(e.count);
    if (needed > available)
      fail(path, "line " + std::to_string(e.line) + ": PLY element '" + e.name + "' declares " +
                     std::to_string(e.count) + " entries, more than the remaining " +
                     std::to_string(data.size() - pos) + " bytes of data can hold");
    if (e.name == "vertex") declaredVertices += e.count;
  }

  PlyValueReader rd(data, pos, lineNo + 1, format, path);
  PolygonSoup soup;
  for (const PlyElement& e : elements) {
    if (e.props.empty()) continue;  // no data to read, whatever the count
    const bool isVertex = e.name == "vertex";
    const bool isFace = e.name == "face";
    int axis[3] = {-1, -1, -1}, iface = -1;
    for (int k = 0; k < static_cast<int>(e.props.size()); ++k) {
      const PlyProperty& pr = e.props[k];
      for (int a = 0; a < 3; ++a)
        if (pr.name == kAxis[a] && !pr.isList) axis[a] = k;
      if ((pr.name == "vertex_indices" || pr.name == "vertex_index") && pr.isList) iface = k;
    }
    if (isVertex && (axis[0] < 0 || axis[1] < 0 || axis[2] < 0))
      fail(path, "line " + std::to_string(e.line) + ": PLY vertex element lacks a scalar x, y or z property");
    if (isFace && iface < 0)
      fail(path, "line " + std::to_string(e.line) + ": PLY face element lacks a vertex_indices list");
    for (long long i = 0; i < e.count; ++i) {  // count <= kMaxCount and fits the data
      Vec3 p = Vec3::Zero();
      std::vector<int> face;
      for (int k = 0; k < static_cast<int>(e.props.size()); ++k) {
        const PlyProperty& pr = e.props[k];
        if (pr.isList) {
          const double n = rd.read(pr.countType, e, i, pr.name);
          if (!(n >= 0 && n <= 1e6))
            rd.failAt(e, i, "list '" + pr.name + "' size " + quoted(rd.text()) + " is out of range (0 to 1000000)");
          const bool indices = isFace && k == iface;
          for (int j = 0; j < static_cast<int>(n); ++j) {  // n <= 1e6; each read fails at the end of the data
            const double v = rd.read(pr.type, e, i, pr.name);
            if (!indices) continue;
            if (!(v >= 0 && v < static_cast<double>(declaredVertices)))
              rd.failAt(e, i,
                        "vertex index " + quoted(rd.text()) + " is out of range: " + vertexRange(declaredVertices));
            if (v != std::floor(v)) rd.failAt(e, i, "vertex index " + quoted(rd.text()) + " is not an integer");
            face.push_back(static_cast<int>(v));
          }
        } else {
          const double v = rd.read(pr.type, e, i, pr.name);
          for (int a = 0; a < 3; ++a)
            if (isVertex && k == axis[a]) {
              if (!std::isfinite(v))
                rd.failAt(e, i,
                          std::string("vertex coordinate ") + kAxis[a] + " " + quoted(rd.text()) + " is not finite");
              if (!(std::abs(v) <= kMaxSurfaceCoordinate))
                rd.failAt(e, i,
                          realProblem(std::string("vertex coordinate ") + kAxis[a], rd.text(), NumberStatus::TooLarge));
              p[a] = v;
            }
        }
      }
      if (isVertex) soup.vertices.push_back(p);
      if (isFace) soup.faces.push_back(std::move(face));
    }
  }
  return soup;
}

std::uint64_t edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

}  // namespace

PolygonSoup readPolygonFile(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    fail(path, "unsupported surface format '." + ext + "' (expected .obj, .off or .ply)");
  return parsePolygonText(readAll(path), ext, path);
}

PolygonSoup parsePolygonText(const std::string& data, const std::string& format, const std::string& path) {
  if (format == "obj") return parseObj(data, path);
  if (format == "off") return parseOff(data, path);
  if (format == "ply") return parsePly(data, path);
  fail(path, "unsupported surface format '." + format + "' (expected .obj, .off or .ply)");
}

TriSurface validateSurface(const PolygonSoup& soup, const std::string& path, std::vector<char>* flippedOut) {
  TriSurface s;
  s.sourcePath = path;
  if (soup.faces.empty()) fail(path, "the surface is empty (no faces)");
  const int nv = static_cast<int>(soup.vertices.size());
  for (int i = 0; i < nv; ++i) {
    if (!soup.vertices[i].allFinite()) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
    if (!(soup.vertices[i].cwiseAbs().maxCoeff() <= kMaxSurfaceCoordinate))
      fail(path, "vertex " + std::to_string(i) + " has a coordinate beyond +-" + formatShort(kMaxSurfaceCoordinate));
  }
  s.vertices = soup.vertices;
  double diag = 0;
  {
    Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
    for (const auto& f : soup.faces)
      for (int v : f)
        if (v >= 0 && v < nv) {
          lo = lo.cwiseMin(soup.vertices[v]);
          hi = hi.cwiseMax(soup.vertices[v]);
        }
    diag = (hi - lo).norm();
  }
  for (std::size_t f = 0; f < soup.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    const std::string fn = "face " + std::to_string(f);
    if (face.size() != 3)
      fail(path, fn + " has " + std::to_string(face.size()) +
                     " corners; only triangle meshes are supported (triangulate the surface first)");
    for (int v : face)
      if (v < 0 || v >= nv)
        fail(path, fn + " refers to vertex " + std::to_string(v) + " (the file has " + std::to_string(nv) + " vertices)");
    if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2])
      fail(path, fn + " is degenerate (it repeats a vertex)");
    const Vec3 &a = s.vertices[face[0]], &b = s.vertices[face[1]], &c = s.vertices[face[2]];
    const double lmax = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const double twiceArea = (b - a).cross(c - a).norm();
    if (!(lmax > 1e-12 * diag) || !(twiceArea > 1e-10 * lmax * lmax))
      fail(path, fn + " is degenerate (zero area: its corners are coincident or collinear)");
    s.faces.push_back({face[0], face[1], face[2]});
  }
  const int nf = static_cast<int>(s.faces.size());
  // Duplicate faces and edges with more than two faces.
  {
    std::map<std::array<int, 3>, int> seen;
    for (int f = 0; f < nf; ++f) {
      auto k = s.faces[f];
      std::sort(k.begin(), k.end());
      auto [it, fresh] = seen.emplace(k, f);
      if (!fresh) fail(path, "face " + std::to_string(f) + " duplicates face " + std::to_string(it->second));
    }
  }
  std::unordered_map<std::uint64_t, std::vector<int>> edgeFaces;
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      auto& v = edgeFaces[edgeKey(s.faces[f][i], s.faces[f][(i + 1) % 3])];
      v.push_back(f);
      if (v.size() > 2) {
        fail(path, "non-manifold edge between vertices " + std::to_string(s.faces[f][i]) + " and " +
                       std::to_string(s.faces[f][(i + 1) % 3]) + ": shared by " + std::to_string(v.size()) +
                       " faces (" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(f) +
                       ")");
      }
    }
  // Orientation: breadth-first over faces, flipping to agree with neighbours.
  std::vector<char> flipped(nf, 0), visited(nf, 0);
  auto hasDirected = [&](int f, int a, int b) {
    const Tri& t = s.faces[f];
    for (int i = 0; i < 3; ++i)
      if (t[i] == a && t[(i + 1) % 3] == b) return true;
    return false;
  };
  for (int start = 0; start < nf; ++start) {
    if (visited[start]) continue;
    visited[start] = 1;
    std::vector<int> queue{start};
    for (std::size_t qi = 0; qi < queue.size(); ++qi) {
      const int f = queue[qi];
      for (int i = 0; i < 3; ++i) {
        const int a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
        for (int g : edgeFaces[edgeKey(a, b)]) {
          if (g == f) continue;
          // Consistent orientation: g traverses the edge as (b, a).
          const bool consistent = hasDirected(g, b, a);
          if (!visited[g]) {
            visited[g] = 1;
            if (!consistent) {
              std::swap(s.faces[g][1], s.faces[g][2]);
              flipped[g] = 1;
            }
            queue.push_back(g);
          } else if (!consistent) {
            fail(path, "the surface is not orientable (faces " + std::to_string(f) + " and " + std::to_string(g) +
                           " cannot be oriented consistently)");
          }
        }
      }
    }
  }
  // Non-manifold vertices: the faces around each vertex must form one fan.
  std::vector<std::vector<int>> vf(nv);
  for (int f = 0; f < nf; ++f)
    for (int v : s.faces[f]) vf[v].push_back(f);
  for (int v = 0; v < nv; ++v) {
    if (vf[v].empty()) continue;
    // Union faces around v that share an edge incident to v.
    std::vector<int> comp(vf[v].size());
    std::iota(comp.begin(), comp.end(), 0);
    std::function<int(int)> find = [&](int x) { return comp[x] == x ? x : comp[x] = find(comp[x]); };
    std::map<int, int> otherToLocal;
    for (int k = 0; k < static_cast<int>(vf[v].size()); ++k) {
      for (int w : s.faces[vf[v][k]]) {
        if (w == v) continue;
        auto [it, fresh] = otherToLocal.emplace(w, k);
        if (!fresh) comp[find(k)] = find(it->second);
      }
    }
    int fans = 0;
    for (int k = 0; k < static_cast<int>(vf[v].size()); ++k)
      if (find(k) == k) ++fans;
    if (fans > 1)
      fail(path, "non-manifold vertex " + std::to_string(v) + ": its faces form " + std::to_string(fans) +
                     " separate fans");
  }
  if (flippedOut) *flippedOut = flipped;
  return s;
}

TriSurface readSurface(const std::string& path) { return validateSurface(readPolygonFile(path), path); }

TriSurface readDeformedCopy(const std::string& path, const TriSurface& rest, const std::vector<char>& restFlips) {
  PolygonSoup soup = readPolygonFile(path);
  if (soup.vertices.size() != rest.vertices.size())
    fail(path, "a deformed copy must have the input surface's connectivity: it has " +
                   std::to_string(soup.vertices.size()) + " vertices, the input surface " +
                   std::to_string(rest.vertices.size()));
  if (soup.faces.size() != rest.faces.size())
    fail(path, "a deformed copy must have the input surface's connectivity: it has " +
                   std::to_string(soup.faces.size()) + " faces, the input surface " +
                   std::to_string(rest.faces.size()));
  TriSurface d;
  d.sourcePath = path;
  d.vertices = soup.vertices;
  for (std::size_t i = 0; i < d.vertices.size(); ++i)
    if (!d.vertices[i].allFinite()) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
  d.faces.resize(rest.faces.size());
  for (std::size_t f = 0; f < rest.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    Tri t = rest.faces[f];
    if (!restFlips.empty() && restFlips[f]) std::swap(t[1], t[2]);  // undo the flip to compare as read
    if (face.size() != 3 || face[0] != t[0] || face[1] != t[1] || face[2] != t[2])
      fail(path, "a deformed copy must have the input surface's connectivity: face " + std::to_string(f) +
                     " differs from the input surface's face " + std::to_string(f));
    d.faces[f] = rest.faces[f];
  }
  return d;
}

Vec3 evalPoint(const TriSurface& s, const SurfacePoint& p) {
  const Tri& t = s.faces[p.face];
  return p.bary[0] * s.vertices[t[0]] + p.bary[1] * s.vertices[t[1]] + p.bary[2] * s.vertices[t[2]];
}

std::vector<Vec3> vertexNormals(const TriSurface& s) {
  std::vector<Vec3> n(s.vertices.size(), Vec3::Zero());
  for (const Tri& t : s.faces) {
    const Vec3 fn = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]).normalized();
    for (int i = 0; i < 3; ++i) {
      const Vec3 e1 = (s.vertices[t[(i + 1) % 3]] - s.vertices[t[i]]).normalized();
      const Vec3 e2 = (s.vertices[t[(i + 2) % 3]] - s.vertices[t[i]]).normalized();
      const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
      n[t[i]] += angle * fn;
    }
  }
  for (Vec3& v : n)
    if (v.norm() > 0) v.normalize();
  return n;
}

Vec3 evalNormal(const TriSurface& s, const std::vector<Vec3>& vn, const SurfacePoint& p) {
  const Tri& t = s.faces[p.face];
  Vec3 n = p.bary[0] * vn[t[0]] + p.bary[1] * vn[t[1]] + p.bary[2] * vn[t[2]];
  if (n.norm() < 1e-9) {
    n = (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]);
  }
  return n.normalized();
}

double faceArea(const TriSurface& s, int f) {
  const Tri& t = s.faces[f];
  return 0.5 * (s.vertices[t[1]] - s.vertices[t[0]]).cross(s.vertices[t[2]] - s.vertices[t[0]]).norm();
}

double surfaceArea(const TriSurface& s) {
  double a = 0;
  for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) a += faceArea(s, f);
  return a;
}

double bboxDiagonal(const TriSurface& s) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const Tri& t : s.faces)
    for (int v : t) {
      lo = lo.cwiseMin(s.vertices[v]);
      hi = hi.cwiseMax(s.vertices[v]);
    }
  return (hi - lo).norm();
}

// Closest point on a triangle (Ericson, Real-Time Collision Detection §5.1.5).
Vec3 closestPointBary(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return Vec3(1, 0, 0);
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return Vec3(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return Vec3(1 - v, v, 0);
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return Vec3(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return Vec3(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return Vec3(0, 1 - w, w);
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return Vec3(1 - v - w, v, w);
}

SurfacePoint closestPoint(const TriSurface& s, const Vec3& p, const std::vector<int>& subset, double* dist) {
  SurfacePoint best;
  double bestD = 1e300;
  auto consider = [&](int f) {
    const Tri& t = s.faces[f];
    const Vec3 b = closestPointBary(p, s.vertices[t[0]], s.vertices[t[1]], s.vertices[t[2]]);
    const Vec3 q = b[0] * s.vertices[t[0]] + b[1] * s.vertices[t[1]] + b[2] * s.vertices[t[2]];
    const double d = (q - p).squaredNorm();
    if (d < bestD) {
      bestD = d;
      best.face = f;
      best.bary = b;
    }
  };
  if (subset.empty())
    for (int f = 0; f < static_cast<int>(s.faces.size()); ++f) consider(f);
  else
    for (int f : subset) consider(f);
  if (dist) *dist = std::sqrt(bestD);
  return best;
}

SurfaceTopology::SurfaceTopology(const TriSurface& s) {
  const int nv = static_cast<int>(s.vertices.size());
  const int nf = static_cast<int>(s.faces.size());
  vertexFaces.assign(nv, {});
  vertexNeighbours.assign(nv, {});
  faceNeighbours.assign(nf, {-1, -1, -1});
  std::unordered_map<std::uint64_t, std::pair<int, int>> edgeFace;  // directed edge -> (face, corner)
  edgeFace.reserve(3 * nf);
  auto dkey = [](int a, int b) { return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b); };
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      vertexFaces[s.faces[f][i]].push_back(f);
      edgeFace[dkey(s.faces[f][i], s.faces[f][(i + 1) % 3])] = {f, i};
    }
  std::unordered_map<int, int> nextOnBoundary;  // boundary edge a->b (as in the face) keyed by a
  for (int f = 0; f < nf; ++f)
    for (int i = 0; i < 3; ++i) {
      const int a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
      auto it = edgeFace.find(dkey(b, a));
      if (it != edgeFace.end()) faceNeighbours[f][i] = it->second.first;
      else nextOnBoundary[a] = b;
      vertexNeighbours[a].push_back(b);
      vertexNeighbours[b].push_back(a);
    }
  for (auto& n : vertexNeighbours) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  isBoundaryVertex.assign(nv, 0);
  std::vector<int> starts;
  for (const auto& kv : nextOnBoundary) {
    isBoundaryVertex[kv.first] = 1;
    starts.push_back(kv.first);
  }
  std::sort(starts.begin(), starts.end());
  std::vector<char> used(nv, 0);
  for (int st : starts) {
    if (used[st]) continue;
    std::vector<int> loop;
    int v = st;
    while (!used[v]) {
      used[v] = 1;
      loop.push_back(v);
      auto it = nextOnBoundary.find(v);
      if (it == nextOnBoundary.end()) break;
      v = it->second;
    }
    boundaryLoops.push_back(std::move(loop));
  }
}

}  // namespace rodmesh::meshing
