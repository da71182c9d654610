// Embree baseline (see embree_solver.h).
#include "lib/raycast/embree_solver.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstring>
#include <limits>

namespace visgate::raycast {

EmbreeScene::EmbreeScene(const TriangleSoup& soup, bool robust) {
  RTCDevice device = rtcNewDevice("verbose=0");
  VG_CHECK(device != nullptr);
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  if (soup.size() > 0) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree-allocated buffers have the tail padding its SIMD loads need.
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), soup.vertices.size()));
    std::memcpy(vb, soup.vertices.data(), soup.vertices.size() * 3 * sizeof(float));
    auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(uint32_t), soup.triangles.size()));
    std::memcpy(ib, soup.triangles.data(), soup.triangles.size() * 3 * sizeof(uint32_t));
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(scene);
  device_ = device;
  scene_ = scene;
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseScene(static_cast<RTCScene>(scene_));
  rtcReleaseDevice(static_cast<RTCDevice>(device_));
}

bool EmbreeScene::occluded(const Vec3f& from, const Vec3f& to) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray;
  ray.org_x = from.x;
  ray.org_y = from.y;
  ray.org_z = from.z;
  Vec3f d = to - from;
  ray.dir_x = d.x;
  ray.dir_y = d.y;
  ray.dir_z = d.z;
  ray.tnear = 0.0f;
  ray.tfar = 1.0f;
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(static_cast<RTCScene>(scene_), &ctx, &ray);
  return ray.tfar == -std::numeric_limits<float>::infinity();
}

SolveResult EmbreeSolver::solve(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  auto t0 = std::chrono::steady_clock::now();
  EmbreeScene es(scene.mesh, robust_);
  auto t1 = std::chrono::steady_clock::now();
  SolveResult result = make_empty_result(scene);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, scene.receivers.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      ReceiverResult& rr = result.receivers[i];
      const Vec3f& r = scene.receivers[i].p;
      size_t bit = 0;
      for (const Light& light : scene.lights)
        for (int j = 0; j < light.samples; ++j, ++bit)
          rr.set_visible(bit, !es.occluded(r, sample_position(light, j, i)));
    }
  });
  auto t2 = std::chrono::steady_clock::now();
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(t2 - t0).count();
  result.stats.set("build_seconds", std::chrono::duration<double>(t1 - t0).count());
  result.stats.set("trace_seconds", std::chrono::duration<double>(t2 - t1).count());
  result.stats.set("relations", double(scene.relation_count()));
  result.stats.set("rays", double(scene.relation_count()));
  return result;
}

}  // namespace visgate::raycast
