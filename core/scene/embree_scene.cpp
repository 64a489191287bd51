#include "core/scene/embree_scene.h"

#include <embree3/rtcore.h>

#include <stdexcept>

namespace fragsim::scene {

void EmbreeErrorLog::record(int code, const char* message) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (count_++ == 0)
    first_ = "Embree error " + std::to_string(code) + ": " + (message ? message : "(no message)");
}

std::string EmbreeErrorLog::first_message() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return first_;
}

std::size_t EmbreeErrorLog::count() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

namespace embree {

namespace {

void on_error(void* user, RTCError code, const char* message) {
  static_cast<EmbreeErrorLog*>(user)->record(static_cast<int>(code), message);
}

[[noreturn]] void throw_last(RTCDevice device, const char* what) {
  throw std::runtime_error(std::string("Embree: ") + what + " failed (error " +
                           std::to_string(static_cast<int>(rtcGetDeviceError(device))) + ")");
}

}  // namespace

RTCDeviceTy* new_device(EmbreeErrorLog* log) {
  // Default configuration: Embree's own thread pool builds the BVH; queries run on the caller's
  // threads.
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device)
    throw std::runtime_error("Embree: cannot create a device (error " +
                             std::to_string(static_cast<int>(rtcGetDeviceError(nullptr))) + ")");
  rtcSetDeviceErrorFunction(device, on_error, log);
  // Ray masks select terrain and/or buildings per query; a build without them would silently
  // ignore the mask, so refuse it.
  if (rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED) == 0) {
    rtcReleaseDevice(device);
    throw std::runtime_error("Embree was built without ray masks (EMBREE_RAY_MASK=OFF)");
  }
  return device;
}

RTCSceneTy* new_scene(RTCDeviceTy* device) {
  RTCScene scene = rtcNewScene(device);
  if (!scene) throw_last(device, "rtcNewScene");
  // ROBUST: watertight triangle test, so a ray through a shared edge or vertex cannot slip
  // between triangles (docs/physics.md, "Reference formulas", numerics). HIGH: SAH BVH with spatial
  // splits; the scene is built once and queried millions of times.
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  return scene;
}

void attach_triangles(RTCDeviceTy* device, RTCSceneTy* scene, unsigned id,
                      const std::vector<Vec3>& vertices,
                      std::span<const std::array<std::uint32_t, 3>> triangles, unsigned mask) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (!geom) throw_last(device, "rtcNewGeometry");
  // rtcSetNewGeometryBuffer pads the buffers as Embree requires (16-byte reads past the end).
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
  auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
  if (!v || !ix) {
    rtcReleaseGeometry(geom);
    throw_last(device, "rtcSetNewGeometryBuffer");
  }
  for (std::size_t k = 0; k < vertices.size(); ++k)
    for (int c = 0; c < 3; ++c) v[3 * k + c] = static_cast<float>(vertices[k][c]);
  for (std::size_t k = 0; k < triangles.size(); ++k)
    for (std::size_t c = 0; c < 3; ++c) ix[3 * k + c] = triangles[k][c];
  rtcSetGeometryMask(geom, mask);
  rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
  rtcCommitGeometry(geom);
  rtcAttachGeometryByID(scene, geom, id);
  rtcReleaseGeometry(geom);  // the scene holds its own reference
}

void commit(RTCSceneTy* scene) {
  rtcCommitScene(scene);
}

void release(RTCDeviceTy* device, RTCSceneTy* scene) {
  if (scene) rtcReleaseScene(scene);
  if (device) rtcReleaseDevice(device);
}

bool intersect1(RTCSceneTy* scene, const Vec3& org, const Vec3& dir, float tnear, float tfar,
                unsigned mask, RayHit& hit) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(org.x());
  rh.ray.org_y = static_cast<float>(org.y());
  rh.ray.org_z = static_cast<float>(org.z());
  rh.ray.dir_x = static_cast<float>(dir.x());
  rh.ray.dir_y = static_cast<float>(dir.y());
  rh.ray.dir_z = static_cast<float>(dir.z());
  rh.ray.tnear = tnear;
  rh.ray.tfar = tfar;
  rh.ray.time = 0.0f;
  rh.ray.mask = mask;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit.t = rh.ray.tfar;
  hit.geom = rh.hit.geomID;
  hit.prim = rh.hit.primID;
  return true;
}

}  // namespace embree
}  // namespace fragsim::scene
