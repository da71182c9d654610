// JSON parsing with exact float32 numbers: a SAX handler that builds an nlohmann::json
// document in which every non-integer number holds strtof(its own text) (stored as a
// double, which represents any float exactly), so no decimal is ever double-rounded.
// Shared by every visgate JSON reader.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lib/base/result.h"

namespace visgate {

// Parses `text`; errors read "<origin>: JSON parse error at byte N: ...".
Result<nlohmann::json> parse_json_exact(const std::string& text, const std::string& origin);
// Reads a whole file; errors name the file.
Result<std::string> read_text_file(const std::string& path);
// Writes `text` to `path` through a temporary file in the same folder and a rename, so
// a failed write leaves nothing behind and never truncates an existing file.
Status write_file_atomic(const std::string& path, const std::string& text);

}  // namespace visgate
