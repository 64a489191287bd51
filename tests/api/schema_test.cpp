// api/schema/scenario.schema.json against the parser.
//
// 1. Statically: every `$defs` object of the schema is a kind of the parser's key table
//    (api/scenario_keys.h) with exactly the same keys, and vice versa; every object schema is
//    closed (additionalProperties: false).
// 2. Behaviourally, walking the bundled examples and a fixture that uses every object kind along
//    with the schema: at every object, the document's keys are schema properties and the schema's
//    required keys are present; the parser rejects an extra key there ("unknown key" at exactly
//    that path); and every schema property the document does not use is recognised by the parser
//    at that place (inserting it yields some error other than "unknown key", or none).
#include <gtest/gtest.h>

#include <set>

#include "api/json_fields.h"
#include "api/scenario_keys.h"
#include "test_support.h"

namespace fragsim::api {
namespace {

using testing::Json;

Json load_schema() {
  return Json::parse(
      testing::read_text(std::filesystem::path(FRAGSIM_SCHEMA_DIR) / "scenario.schema.json"));
}

std::string def_name(const std::string& ref) {
  const std::string prefix = "#/$defs/";
  EXPECT_EQ(ref.rfind(prefix, 0), 0u) << ref;
  return ref.substr(prefix.size());
}

void expect_closed_objects(const Json& node, const std::string& where) {
  if (node.is_object()) {
    if (node.contains("properties")) {
      EXPECT_EQ(node.value("additionalProperties", Json(true)), Json(false))
          << where << " must set additionalProperties: false";
    }
    for (const auto& [key, child] : node.items()) expect_closed_objects(child, where + "/" + key);
  } else if (node.is_array()) {
    for (std::size_t k = 0; k < node.size(); ++k)
      expect_closed_objects(node[k], where + "/" + std::to_string(k));
  }
}

TEST(ScenarioSchema, IsDraft202012AndClosed) {
  const Json schema = load_schema();
  EXPECT_EQ(schema["$schema"], "https://json-schema.org/draft/2020-12/schema");
  EXPECT_EQ(schema["$ref"], "#/$defs/scenario");
  expect_closed_objects(schema, "#");
}

TEST(ScenarioSchema, ObjectDefinitionsMatchTheParserKeyTable) {
  const Json defs = load_schema()["$defs"];
  std::set<std::string> schema_kinds;
  for (const auto& [name, def] : defs.items()) {
    if (!def.contains("properties")) continue;
    schema_kinds.insert(name);
    std::vector<std::string> properties;
    for (const auto& [key, value] : def["properties"].items()) {
      properties.push_back(key);
      EXPECT_TRUE(value.contains("description") || value.contains("$ref"))
          << name << "." << key << " has no description";
    }
    ASSERT_TRUE(scenario_object_keys().count(name)) << "$defs/" << name << " is not a parser kind";
    std::vector<std::string> parser = object_keys(name);
    std::sort(properties.begin(), properties.end());
    std::sort(parser.begin(), parser.end());
    EXPECT_EQ(properties, parser) << "keys of " << name;
    for (const auto& r : def.value("required", Json::array()))
      EXPECT_TRUE(def["properties"].contains(r.get<std::string>())) << name << " requires " << r;
  }
  for (const auto& [kind, keys] : scenario_object_keys())
    EXPECT_TRUE(schema_kinds.count(kind)) << "parser kind " << kind << " has no $defs entry";
}

// Walks a document along the schema and runs the checks of point 2 above at every object.
class SchemaWalk {
 public:
  SchemaWalk(const Json& schema, const Json& document) : defs_(schema["$defs"]), doc_(document) {}

  void run() {
    ASSERT_EQ(testing::parse_error(doc_), (testing::FieldMessage{"<no error>", ""}));
    walk(doc_, Json{{"$ref", "#/$defs/scenario"}}, "", Json::json_pointer());
  }
  const std::set<std::string>& visited() const { return visited_; }

 private:
  // Resolves $ref (remembering the kind) and, for oneOf, picks the alternative the value fits.
  std::pair<Json, std::string> resolve(const Json& instance, Json node, std::string kind,
                                       const std::string& path) {
    for (int guard = 0; guard < 8; ++guard) {
      if (node.contains("$ref")) {
        kind = def_name(node["$ref"]);
        node = defs_[kind];
        continue;
      }
      if (node.contains("oneOf") && !node.contains("properties")) {
        Json chosen;
        std::string chosen_kind;
        for (const auto& alternative : node["oneOf"]) {
          Json alt = alternative;
          std::string alt_kind;
          if (alt.contains("$ref")) {
            alt_kind = def_name(alt["$ref"]);
            alt = defs_[alt_kind];
          }
          if (!instance.is_object()) {
            if (!alt.contains("properties")) chosen = alt;  // a scalar alternative
            continue;
          }
          if (!alt.contains("properties")) continue;
          const Json& props = alt["properties"];
          bool fits = true;
          for (const auto& [key, value] : instance.items()) fits = fits && props.contains(key);
          if (props.contains("dist"))
            fits = fits && instance.contains("dist") && props["dist"]["const"] == instance["dist"];
          if (fits) {
            chosen = alt;
            chosen_kind = alt_kind;
          }
        }
        EXPECT_FALSE(chosen.is_null()) << "no schema alternative fits " << path;
        node = chosen;
        kind = chosen_kind;
        continue;
      }
      break;
    }
    return {node, kind};
  }

  void walk(const Json& instance, const Json& schema_node, const std::string& path,
            const Json::json_pointer& where) {
    const auto [node, kind] = resolve(instance, schema_node, "", path);
    if (node.is_null()) return;
    if (instance.is_array() && node.contains("items")) {
      for (std::size_t k = 0; k < instance.size(); ++k)
        walk(instance[k], node["items"], index_path(path, k), where / k);
      return;
    }
    if (!instance.is_object()) return;
    if (node.contains("additionalProperties") && node["additionalProperties"].is_object()) {
      for (const auto& [key, value] : instance.items())  // a map (site.materials)
        walk(value, node["additionalProperties"], child_path(path, key), where / key);
      return;
    }
    ASSERT_TRUE(node.contains("properties")) << "no object schema at " << path;
    visited_.insert(kind);
    check_object(instance, node, path, where);
    for (const auto& [key, value] : instance.items())
      walk(value, node["properties"][key], child_path(path, key), where / key);
  }

  void check_object(const Json& instance, const Json& node, const std::string& path,
                    const Json::json_pointer& where) {
    const Json& props = node["properties"];
    for (const auto& [key, value] : instance.items())
      EXPECT_TRUE(props.contains(key)) << path << ": key " << key << " is not in the schema";
    for (const auto& r : node.value("required", Json::array()))
      EXPECT_TRUE(instance.contains(r.get<std::string>()))
          << path << ": required " << r << " missing";

    Json extra = doc_;
    extra[where]["zz_not_a_key"] = 1;
    EXPECT_EQ(testing::parse_error(extra),
              (testing::FieldMessage{child_path(path, "zz_not_a_key"), "unknown key"}));

    for (const auto& [key, value] : props.items()) {
      if (instance.contains(key)) continue;
      Json added = doc_;
      added[where][key] = nullptr;
      const auto [field, message] = testing::parse_error(added);
      EXPECT_FALSE(field == child_path(path, key) && message.rfind("unknown key", 0) == 0)
          << "the parser does not accept schema property " << child_path(path, key);
    }
  }

  const Json defs_;
  const Json& doc_;
  std::set<std::string> visited_;
};

TEST(ScenarioSchema, ExamplesWalkConsistentlyWithTheParser) {
  const Json schema = load_schema();
  std::set<std::string> visited;
  for (const Json& doc : {testing::minimal_example(), testing::kitchen_sink()}) {
    SchemaWalk walk(schema, doc);
    walk.run();
    visited.insert(walk.visited().begin(), walk.visited().end());
  }
  // The demo's grid terrain; its 40401 elevations make a full mutation walk slow, so only its
  // site is walked (the rest repeats the minimal example's kinds).
  {
    Json demo = testing::demo_example();
    demo["site"]["terrain"]["grid"]["nx"] = 2;
    demo["site"]["terrain"]["grid"]["ny"] = 2;
    demo["site"]["terrain"]["grid"]["elevation_m"] = {0, 0, 0, 0};
    SchemaWalk walk(schema, demo);
    walk.run();
    visited.insert(walk.visited().begin(), walk.visited().end());
  }
  for (const auto& [kind, keys] : scenario_object_keys())
    EXPECT_TRUE(visited.count(kind)) << "no test document uses object kind " << kind;
}

TEST(ScenarioSchema, MinimalExampleHasTheRequiredTopLevelKeys) {
  const Json schema = load_schema();
  const Json example = testing::minimal_example();
  for (const auto& r : schema["$defs"]["scenario"]["required"])
    EXPECT_TRUE(example.contains(r.get<std::string>())) << r;
  EXPECT_EQ(example["schema"], schema["$defs"]["scenario"]["properties"]["schema"]["const"]);
}

}  // namespace
}  // namespace fragsim::api
