#pragma once
// Provenance: a one-line description of the machine a run ran on, stored in results.h5 (root
// attribute `machine`, format 5) and shown in the study report (host name, CPU model and count,
// kernel); and the time stamps of results.h5 and the report.
#include <string>

namespace fragsim::api {

// Now, UTC, ISO 8601 to the second: "2026-11-28T12:05:30Z".
std::string utc_now_iso8601();

// "host01: Intel(R) Xeon(R) Gold 6248 CPU @ 2.50GHz, 2 CPUs, Linux 6.1.0-26-amd64 x86_64";
// parts that cannot be read are left out.
std::string machine_description();

}  // namespace fragsim::api
