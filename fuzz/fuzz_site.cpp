// libFuzzer target: bytes as the body of fragsimd's POST /v1/sites (a site document), parsed and
// built as the daemon does before storing it.
#include <cstddef>
#include <cstdint>

#include "api/site_document.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fragsim;
  api::SiteDocument doc;
  try {
    doc = api::parse_site_document(api::parse_json_text(fuzz::as_text(data, size)));
    if (fuzz::too_large_to_build(doc.spec.terrain)) return 0;
    (void)api::build_site(doc);
  } catch (const InputError&) {
    return 0;
  }
  // A site's id is the hash of its normalised JSON: uploading the normalised form must give the
  // same id, or the daemon would store one site twice.
  const api::SiteDocument again = api::parse_site_document(doc.normalised);
  if (again.site_id != doc.site_id)
    fuzz::fail("site id changes when the normalised site is uploaded:\n" + doc.normalised.dump() +
               "\n" + again.normalised.dump());
  return 0;
}
