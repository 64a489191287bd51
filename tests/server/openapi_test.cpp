// api/openapi.yaml (served at GET /v1/openapi.yaml) describes exactly the routes the service
// dispatches, with the same methods and the same public routes.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>
#include <string>

#include "server/openapi_text.h"
#include "server/service.h"

namespace fragsim::server {
namespace {

struct SpecRoute {
  std::set<std::string> methods;
  std::set<std::string> public_methods;  // with "security: []"
};

// The paths block of the YAML read by indentation: "  /path:" then "    get:" and, inside an
// operation, "      security: []".
std::map<std::string, SpecRoute> spec_routes(std::string_view yaml) {
  std::map<std::string, SpecRoute> out;
  std::istringstream in{std::string(yaml)};
  std::string line, path, method;
  bool in_paths = false;
  static const std::set<std::string> kMethods = {"get", "post", "put", "patch", "delete"};
  while (std::getline(in, line)) {
    if (line.rfind("paths:", 0) == 0) {
      in_paths = true;
      continue;
    }
    if (!in_paths) continue;
    if (!line.empty() && line[0] != ' ' && line[0] != '#') break;  // next top-level key
    if (line.rfind("  /", 0) == 0 && line.back() == ':') {
      path = line.substr(2, line.size() - 3);
      method.clear();
      out[path];
    } else if (line.rfind("    ", 0) == 0 && line.size() > 5 && line[4] != ' ' &&
               line.back() == ':') {
      const std::string key = line.substr(4, line.size() - 5);
      method = kMethods.count(key) ? key : "";
      if (!method.empty()) out[path].methods.insert(method);
    } else if (!method.empty() && line == "      security: []") {
      out[path].public_methods.insert(method);
    }
  }
  return out;
}

std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

TEST(OpenApi, DescribesExactlyTheServedRoutes) {
  const auto spec = spec_routes(openapi_yaml());
  ASSERT_FALSE(spec.empty());
  std::set<std::string> served;
  for (const RouteInfo& r : route_table()) {
    served.insert(r.pattern);
    const auto it = spec.find(r.pattern);
    ASSERT_NE(it, spec.end()) << r.pattern << " is served but not in api/openapi.yaml";
    std::set<std::string> methods;
    for (const auto& m : it->second.methods) methods.insert(upper(m));
    EXPECT_EQ(methods, std::set<std::string>(r.methods.begin(), r.methods.end())) << r.pattern;
    if (r.public_route) {
      EXPECT_EQ(it->second.public_methods, it->second.methods) << r.pattern << " is public";
    } else {
      EXPECT_TRUE(it->second.public_methods.empty()) << r.pattern << " needs a token";
    }
  }
  for (const auto& [path, route] : spec)
    EXPECT_TRUE(served.count(path)) << path << " is in api/openapi.yaml but not served";
}

TEST(OpenApi, IsAnOpenApi3Document) {
  const std::string_view yaml = openapi_yaml();
  EXPECT_EQ(yaml.substr(0, yaml.find('\n')).find("openapi: 3."), 0u) << yaml.substr(0, 40);
  EXPECT_NE(yaml.find("bearerAuth"), std::string_view::npos);
}

}  // namespace
}  // namespace fragsim::server
