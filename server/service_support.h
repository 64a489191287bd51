#pragma once
// What the Service's route handlers share (server/service*.cpp only; not a public header).
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "server/service.h"

namespace fragsim::server {

using OJson = nlohmann::ordered_json;

inline constexpr const char* kJsonType = "application/json";

// Strings in a body are valid UTF-8 by construction (client text passes escape_invalid_utf8);
// should one not be, it is replaced rather than turning the answer into an exception.
Response json_response(int status, const OJson& j);
// A new job id: "j_" and 16 hex digits.
std::string new_job_id();
// Query parameters a route accepts; anything else is refused (a misspelt filter would otherwise
// silently return everything).
std::optional<Response> check_query(const Request& req, std::initializer_list<const char*> known);
// Text -> JSON with the 400 errors of the contract.
nlohmann::json parse_body(const Request& req);
// A query parameter's value as a finite number, the whole text and nothing else.
std::optional<double> query_number(const std::string& text);
// 415 unless the body is sent as application/json.
std::optional<Response> check_json_content_type(const Request& req);

}  // namespace fragsim::server
