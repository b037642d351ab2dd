// shrmd's optional config file (`shrmd --config FILE`, docs/server.md "Config file"): one
// `key = value` a line, the keys being the long flag names without "--" (listen, max-jobs, ...).
// Blank lines and lines starting with '#' are skipped; whitespace around key and value is
// trimmed; a value may be wrapped in double quotes (kept verbatim inside). Boolean flags take
// true/false. Flags given on the command line override the file.
#ifndef SHRM_SERVER_CONFIG_FILE_H_
#define SHRM_SERVER_CONFIG_FILE_H_

#include <functional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::server {

struct ConfigEntry {
  std::string key;
  std::string value;
  int line = 0;  // 1-based, for messages
};

// Parses the text of a config file. InvalidArgument (naming the line) for a line without '=',
// an empty key, a key starting with '-', a key given twice, an unterminated quote, or a NUL byte.
absl::StatusOr<std::vector<ConfigEntry>> ParseConfigText(std::string_view text);

// Reads and parses `path` (NotFound when it cannot be read; messages do not repeat the path).
absl::StatusOr<std::vector<ConfigEntry>> ReadConfigFile(const std::string& path);

// Command-line arguments equivalent to `entries`, skipping keys for which `given(key)` is true
// (flags already on the command line win). Keys in `bool_flags` become "--key" for true and
// nothing for false (InvalidArgument for another value); others become "--key", "value".
// InvalidArgument for a key `known(key)` rejects, and for help, version and config (actions of
// the command line, not settings).
absl::StatusOr<std::vector<std::string>> ConfigToArgs(
    const std::vector<ConfigEntry>& entries, const std::set<std::string>& bool_flags,
    const std::function<bool(const std::string&)>& known,
    const std::function<bool(const std::string&)>& given);

}  // namespace shrm::server

#endif  // SHRM_SERVER_CONFIG_FILE_H_
