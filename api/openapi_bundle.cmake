# The served contract: api/openapi.yaml with the scenario JSON Schema's definitions inlined.
#
# api/openapi.yaml refers to the scenario and site formats by
# `$ref: "schema/scenario.schema.json#/$defs/NAME"`, so that api/schema/scenario.schema.json stays
# their one description (docs/http-api.md, "The contract document"). A served document must be
# self-contained: this script copies every `$defs` entry of the schema into the document's
# `components/schemas` as `scenario.NAME` (at the line "# @scenario-schema-defs@", which must be
# the last line of components/schemas) and points every reference, the schema's own included, at
# the copy. OpenAPI 3.1 takes JSON Schema 2020-12 as it is, so nothing else changes. The copies
# are written as JSON (YAML's flow style), re-serialised by CMake: same values, keys sorted.
#
# Use: include() with FRAGSIM_OPENAPI_SOURCE, FRAGSIM_SCENARIO_SCHEMA and FRAGSIM_OPENAPI_BUNDLE set.
# tests/server/contract_test.py checks that each copy equals its source.

file(READ ${FRAGSIM_OPENAPI_SOURCE} _yaml)
file(READ ${FRAGSIM_SCENARIO_SCHEMA} _schema)
set(_marker "    # @scenario-schema-defs@\n")
string(FIND "${_yaml}" "${_marker}" _at)
if(_at EQUAL -1)
  message(FATAL_ERROR "${FRAGSIM_OPENAPI_SOURCE}: no line \"${_marker}\" (where the scenario "
                      "schema's definitions go)")
endif()

set(_ref_from "schema/scenario.schema.json#/$defs/")
set(_ref_to "#/components/schemas/scenario.")
string(JSON _count LENGTH "${_schema}" "$defs")
math(EXPR _last "${_count} - 1")
set(_defs "    # Inlined from api/schema/scenario.schema.json $defs by api/openapi_bundle.cmake.\n")
foreach(_i RANGE ${_last})
  string(JSON _name MEMBER "${_schema}" "$defs" ${_i})
  string(JSON _def GET "${_schema}" "$defs" ${_name})
  string(REPLACE "\"#/$defs/" "\"${_ref_to}" _def "${_def}")
  string(REPLACE "\n" "\n      " _def "${_def}")
  string(APPEND _defs "    scenario.${_name}:\n      ${_def}\n")
endforeach()

string(REPLACE "${_ref_from}" "${_ref_to}" _yaml "${_yaml}")
string(REPLACE "${_marker}" "${_defs}" _yaml "${_yaml}")
file(WRITE ${FRAGSIM_OPENAPI_BUNDLE}.tmp "${_yaml}")
configure_file(${FRAGSIM_OPENAPI_BUNDLE}.tmp ${FRAGSIM_OPENAPI_BUNDLE} COPYONLY)
