#pragma once
// The only place that talks to Embree (3.x). Site keeps opaque device/scene handles and calls
// these functions; a port to Embree 4 (rtcIntersect1 arguments, RTCRayQueryContext) changes this
// file and embree_scene.cpp only.
#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "core/common/types.h"

struct RTCDeviceTy;
struct RTCSceneTy;

namespace fragsim::scene {

// Messages from the device's error callback. Embree may call it from any thread.
struct EmbreeErrorLog {
  void record(int code, const char* message);
  std::string first_message() const;  // empty if none
  std::size_t count() const;

 private:
  mutable std::mutex mutex_;
  std::string first_;
  std::size_t count_ = 0;
};

namespace embree {

// A device whose error callback writes to `log` (which must outlive the device).
// Throws std::runtime_error if Embree cannot create one.
RTCDeviceTy* new_device(EmbreeErrorLog* log);
// A scene for static, robust (watertight) queries with a high-quality BVH.
RTCSceneTy* new_scene(RTCDeviceTy* device);
// Adds a triangle geometry under geometry id `id`, visible to rays whose mask shares a bit with
// `mask`. Vertices are site-local doubles, stored by Embree as floats.
void attach_triangles(RTCDeviceTy* device, RTCSceneTy* scene, unsigned id,
                      const std::vector<Vec3>& vertices,
                      std::span<const std::array<std::uint32_t, 3>> triangles, unsigned mask);
void commit(RTCSceneTy* scene);
void release(RTCDeviceTy* device, RTCSceneTy* scene);  // either may be null

struct RayHit {
  float t = 0;
  unsigned geom = 0;
  unsigned prim = 0;
};
// Nearest hit of the float ray org + t dir, t in [tnear, tfar], against geometries matching
// `mask`. Thread-safe on a committed scene; the context and ray live on the caller's stack.
bool intersect1(RTCSceneTy* scene, const Vec3& org, const Vec3& dir, float tnear, float tfar,
                unsigned mask, RayHit& hit);

}  // namespace embree
}  // namespace fragsim::scene
