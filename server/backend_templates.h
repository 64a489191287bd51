#pragma once
// The argv templates of an external backend's commands (server/backend.h): placeholders such as
// {shard} and {ids} in submit, status and cancel, expanded when a job is submitted or followed.
#include <map>
#include <set>
#include <string>
#include <vector>

namespace fragsim::server {

// Placeholders are {name} with name in [a-z_]; other braces (${i}, %{x}, {X}) are plain text.
struct Piece {
  bool placeholder = false;
  std::string text;  // literal text, or the placeholder's name
};
std::vector<Piece> split_template(const std::string& s);

// InputError naming `key`[i] for a placeholder not in `known`.
void check_placeholders(const std::vector<std::string>& argv, const std::string& key,
                        const std::set<std::string>& known);
// True when an argument holds the placeholder {name}.
bool mentions(const std::vector<std::string>& argv, const std::string& name);
// Replaces the placeholders found in `vars`; others are left as they are ({ids}, expanded later).
std::string expand(const std::string& s, const std::map<std::string, std::string>& vars);
std::vector<std::string> expand_all(const std::vector<std::string>& argv,
                                    const std::map<std::string, std::string>& vars);
// A word for /bin/sh: single-quoted.
std::string shell_quote(const std::string& s);

}  // namespace fragsim::server
