// JSON text from untrusted files: parsing with errors that say where, and
// bounded printing of values for messages. Used by the scene reader.
//
// parseJsonText rejects, with an InputError naming the file:
//   - nesting deeper than kMaxJsonDepth arrays/objects (checked by a scan of
//     the text before any parsing: "line L, column C: nesting deeper than
//     ..."), so that no later recursion over the value can run out of stack;
//   - syntax errors: the line and column, what the parser expected, the text
//     it read, and the key path of the enclosing value;
//   - numbers beyond the double range ("1e999"): the key path of the number,
//     its text, line and column.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>

namespace rodmesh {

// A scene needs 5 levels ({"poses": [{"fixed": [{"position": [...]}]}]}).
constexpr int kMaxJsonDepth = 64;

// Parses `text` (read from `path`; used in messages only). Throws InputError.
nlohmann::json parseJsonText(const std::string& text, const std::string& path);

// The value as compact JSON for a message, at most about `maxChars`
// characters ("..." marks a cut). Cost and recursion depth are bounded by
// `maxChars`, whatever the size and depth of the value.
std::string shortJson(const nlohmann::json& j, std::size_t maxChars = 60);

// Text from a file as a quoted, escaped JSON string of at most about
// `maxChars` characters: control characters never reach a message.
std::string quotedText(const std::string& text, std::size_t maxChars = 60);

// `path` extended by object key `key`: "path.key" for plain keys (letters,
// digits, '_'), else path["escaped key"] (shortened), so that a key path is
// one line whatever the key.
std::string withKey(const std::string& path, const std::string& key);

}  // namespace rodmesh
