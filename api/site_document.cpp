#include "api/site_document.h"

#include "api/sha256.h"
#include "api/site_json.h"

namespace fragsim::api {

namespace {

constexpr std::string_view kSitePrefix = "site.";

// scene::Site::build names elements as in a scenario ("site.buildings[2]..."); a site document
// is the site itself.
std::string site_relative(const std::string& field) {
  if (field == "site") return "";
  if (field.compare(0, kSitePrefix.size(), kSitePrefix) == 0)
    return field.substr(kSitePrefix.size());
  return field;
}

bool is_lower_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
}

}  // namespace

SiteDocument parse_site_document(const nlohmann::json& j) {
  if (!j.is_object())
    fail("", "expected a JSON object (a site) at the top level, got " + json_type_name(j));
  SiteDocument doc;
  doc.spec = detail::parse_site(j, "", doc.material_notes);
  doc.normalised = detail::site_to_json(doc.spec, &doc.material_notes);
  doc.site_id = "s_" + sha256_hex(doc.normalised.dump()).substr(0, 16);
  return doc;
}

std::shared_ptr<const scene::Site> build_site(const SiteDocument& doc) {
  try {
    return scene::Site::build(doc.spec);
  } catch (const InputError& e) {
    throw InputError(site_relative(e.field()), e.message());
  }
}

bool is_site_id(std::string_view s) {
  if (s.size() != 18 || s[0] != 's' || s[1] != '_') return false;
  for (std::size_t k = 2; k < s.size(); ++k)
    if (!is_lower_hex(s[k])) return false;
  return true;
}

}  // namespace fragsim::api
