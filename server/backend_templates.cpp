#include "server/backend_templates.h"

#include <algorithm>

#include "core/common/error.h"

namespace fragsim::server {

std::vector<Piece> split_template(const std::string& s) {
  std::vector<Piece> out;
  std::string literal;
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s[k] == '{' && (k == 0 || (s[k - 1] != '$' && s[k - 1] != '%'))) {
      const std::size_t close = s.find('}', k + 1);
      if (close != std::string::npos && close > k + 1) {
        const std::string name = s.substr(k + 1, close - k - 1);
        if (std::all_of(name.begin(), name.end(),
                        [](char c) { return (c >= 'a' && c <= 'z') || c == '_'; })) {
          if (!literal.empty()) out.push_back({false, std::move(literal)});
          literal.clear();
          out.push_back({true, name});
          k = close;
          continue;
        }
      }
    }
    literal += s[k];
  }
  if (!literal.empty()) out.push_back({false, std::move(literal)});
  return out;
}

void check_placeholders(const std::vector<std::string>& argv, const std::string& key,
                        const std::set<std::string>& known) {
  for (std::size_t i = 0; i < argv.size(); ++i)
    for (const auto& p : split_template(argv[i]))
      if (p.placeholder && known.count(p.text) == 0) {
        std::string list;
        for (const auto& n : known) list += (list.empty() ? "{" : ", {") + n + "}";
        throw InputError(key + "[" + std::to_string(i) + "]",
                         "unknown placeholder {" + p.text + "} (known here: " + list + ")");
      }
}

bool mentions(const std::vector<std::string>& argv, const std::string& name) {
  for (const auto& a : argv)
    for (const auto& p : split_template(a))
      if (p.placeholder && p.text == name) return true;
  return false;
}

std::string expand(const std::string& s, const std::map<std::string, std::string>& vars) {
  std::string out;
  for (const auto& p : split_template(s)) {
    if (!p.placeholder) {
      out += p.text;
      continue;
    }
    const auto it = vars.find(p.text);
    if (it == vars.end()) {
      out += '{';
      out += p.text;
      out += '}';
    } else {
      out += it->second;
    }
  }
  return out;
}

std::vector<std::string> expand_all(const std::vector<std::string>& argv,
                                    const std::map<std::string, std::string>& vars) {
  std::vector<std::string> out;
  for (const auto& a : argv) out.push_back(expand(a, vars));
  return out;
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  out += '\'';
  return out;
}

}  // namespace fragsim::server
