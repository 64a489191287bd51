#pragma once
// The keys each kind of JSON object in a scenario accepts. One table, used by the parser to reject
// unknown keys and by the schema test to check api/schema/scenario.schema.json against the parser:
// every kind here is a `$defs` entry of the schema with exactly these `properties` (the root
// object is kind "scenario").
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace fragsim::api {

// kind -> accepted keys, in documentation order.
const std::map<std::string, std::vector<std::string>, std::less<>>& scenario_object_keys();

// Keys of one kind; throws std::logic_error for an unknown kind (a programming error).
const std::vector<std::string>& object_keys(std::string_view kind);

}  // namespace fragsim::api
