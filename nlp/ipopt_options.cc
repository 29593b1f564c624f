// Checking ./ipopt.opt before a run: the file is read the way Ipopt reads it
// (whitespace-separated tokens, '#' to the end of a line a comment, a value
// may be quoted with '"'), and every KEY VALUE pair goes through
// checkIpoptOption, so that an option file Ipopt would reject, or silently
// ignore a line of, is a usage error that names the line, the key and the
// value before any work. No Ipopt header is needed here.
#include "nlp/sand.hh"

#include <sys/stat.h>

#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace rodmesh {
namespace {

constexpr const char* kOptionsFile = "./ipopt.opt";
// An options file is a few lines; a larger one is a mistake (or not a file).
constexpr long long kMaxOptionsFileBytes = 1 << 20;

struct Token {
  std::string text;
  int line = 0;
};

// Shows a token from the file in a one-line message.
std::string shown(const std::string& text) {
  std::string out;
  for (unsigned char c : text.substr(0, 80)) {
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out.push_back(static_cast<char>(c));
    }
  }
  return text.size() > 80 ? out + "..." : out;
}

}  // namespace

bool ipoptOptionsFilePresent() {
  struct stat st;
  return ::stat(kOptionsFile, &st) == 0;
}

std::string checkIpoptOptionsFile() {
  struct stat st;
  if (::stat(kOptionsFile, &st) != 0) return "";
  const std::string file = kOptionsFile;
  if (!S_ISREG(st.st_mode)) return file + ": not a regular file; Ipopt cannot read it as its options file";
  if (st.st_size > kMaxOptionsFileBytes)
    return file + ": " + std::to_string(st.st_size) + " bytes; an options file of more than 1 MiB is not read";
  std::ifstream in(kOptionsFile, std::ios::binary);
  if (!in) return file + ": cannot be read";
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();

  std::vector<Token> tokens;
  int line = 1;
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '"') {
      const std::size_t close = text.find('"', i + 1);
      if (close == std::string::npos)
        return file + ": line " + std::to_string(line) + ": a quoted value without its closing '\"'";
      Token t{text.substr(i + 1, close - i - 1), line};
      for (std::size_t k = i; k < close; ++k) line += text[k] == '\n';
      tokens.push_back(std::move(t));
      i = close + 1;
    } else {
      std::size_t e = i;
      while (e < text.size() && !std::isspace(static_cast<unsigned char>(text[e])) && text[e] != '#') ++e;
      tokens.push_back(Token{text.substr(i, e - i), line});
      i = e;
    }
  }
  // One option per line: KEY VALUE. A key alone on its line would take the
  // next line's key as its value (or, at the end, be dropped) in Ipopt.
  for (std::size_t k = 0; k < tokens.size(); k += 2) {
    const Token& key = tokens[k];
    const std::string at = file + ": line " + std::to_string(key.line) + ": ";
    if (k + 1 >= tokens.size() || tokens[k + 1].line != key.line)
      return at + "option '" + shown(key.text) + "' has no value (each line is KEY VALUE)";
    if (k + 2 < tokens.size() && tokens[k + 2].line == key.line)
      return at + "more than KEY VALUE on one line, got '" + shown(tokens[k + 2].text) + "' after '" +
             shown(key.text) + " " + shown(tokens[k + 1].text) + "'";
    if (std::string why = checkIpoptOption(key.text, tokens[k + 1].text); !why.empty()) return at + shown(why);
  }
  return "";
}

}  // namespace rodmesh
