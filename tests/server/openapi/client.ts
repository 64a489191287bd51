// What a front end's build does with the contract: types generated from the served document
// (openapi-typescript, into fragsimd.d.ts by run.sh) and code that uses them, type-checked with
// tsc --strict. It is never run; it fails to compile if the document stops typing a request or
// an answer a client relies on.
import type { components, paths } from "./fragsimd";

type Schemas = components["schemas"];
type JobRequest = Schemas["JobRequest"];
type JobStatus = paths["/v1/jobs/{id}"]["get"]["responses"]["200"]["content"]["application/json"];
type ApiError = Schemas["Error"];

// A job on a registered site: the scenario's own types (mass distribution, terrain) are checked.
export const request: JobRequest = {
  schema: "fragsim.scenario/1",
  site_id: "s_0123456789abcdef",
  priority: 10,
  fragment_groups: [
    {
      name: "steel spheres",
      count: 1000,
      samples: 2000,
      frame: { origin_m: [0, 0, 1] },
      shape: { type: "sphere", density_kg_m3: 7850 },
      mass_kg: { dist: "lognormal", median: 0.05, sigma_ln: 0.5 },
      speed_mps: { dist: "normal", mean: 300, sigma: 40 },
      direction: { elevation_deg: [0, 45], azimuth_deg: [-180, 180] },
      cd: 0.47,
    },
  ],
  settings: { seed: 42 },
};

export const site: Schemas["Site"] = {
  terrain: { plane: { elevation_m: 0, extent_m: [-100, -100, 100, 100], cell_m: 10 }, material: "soil" },
  materials: { soil: { friction: 0.9, restitution: 0.2 } },
};

export function describe(job: JobStatus): string {
  const eta = job.eta_s === null ? "" : ` (${job.eta_s.toFixed(0)} s left)`;
  const precision = job.precision === null ? "" : ` targets met: ${job.precision.all_met}`;
  return `${job.job_id} ${job.state} ${(job.progress * 100).toFixed(0)} %${eta}${precision}`;
}

export function hfd(summary: Schemas["Summary"]): string {
  const bound = summary.hfd_bound === "lower" ? ">= " : "";
  const impacts = summary.buildings.map((b) => `${b.id}: ${b.by_surface.wall.expected_impacts}`);
  return `${bound}${summary.hazardous_fragment_distance_m} m; ${impacts.join(", ")}`;
}

export function explain(e: ApiError): string {
  switch (e.code) {
    case "invalid_input":
    case "limit_exceeded":
      return `${e.field ?? "the request"}: ${e.message}`;
    case "too_many_connections":
    case "busy":
      return "retry later";
    default:
      return e.message;
  }
}
