// Embree baseline (see embree_solver.h).
#include "lib/raycast/embree_solver.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>

#include "lib/geom/predicates.h"

namespace visgate::raycast {

namespace {

// The process-wide Embree device (see EmbreeScene): created once, thread-safe by the
// C++ static initialisation guarantee; never released (reachable through the static, so
// leak checkers do not count it), which avoids tearing Embree down after TBB at exit.
RTCDevice shared_device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice("verbose=0");
    VG_CHECK(d != nullptr);
    return d;
  }();
  return device;
}

// Sign of a double as -1, 0, +1.
int sign_of(double v) { return (v > 0.0) - (v < 0.0); }

}  // namespace

bool within_embree_bound(const Vec3f& p) {
  return std::abs(p.x) <= kEmbreeCoordinateBound && std::abs(p.y) <= kEmbreeCoordinateBound &&
         std::abs(p.z) <= kEmbreeCoordinateBound;
}

bool fallback_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to) {
  const Vec3d p = to_double(from), q = to_double(to);
  for (const auto& t : soup.triangles) {
    const Vec3d a = to_double(soup.vertices[t[0]]), b = to_double(soup.vertices[t[1]]),
                c = to_double(soup.vertices[t[2]]);
    // Signed distances (times |n|) of the endpoints from the triangle's plane; the
    // receiver end strictly off the plane, the light end on the other side or on it
    // (t in (0, 1]). n comes from the triangle alone, so its relative error is 1e-16
    // whatever the endpoints' magnitude.
    const Vec3d n = cross(b - a, c - a);
    const double dp = dot(n, p - a), dq = dot(n, q - a);
    const int sp = sign_of(dp), sq = sign_of(dq);
    if (sp == 0 || sp == sq) continue;
    // The crossing point, computed from the endpoint nearer to the plane so that its
    // error is 1e-16 of that endpoint's distance, not of the segment's length (a far
    // receiver, 1e22 away, must not blur a unit triangle).
    Vec3d x;
    if (sq == 0) x = q;
    else if (std::abs(dq) <= std::abs(dp)) x = q + (p - q) * (dq / (dq - dp));
    else x = p + (q - p) * (dp / (dp - dq));
    // Closed point-in-triangle test in the projection that drops n's dominant axis:
    // the three edge cross products agree in sign (zeros allowed).
    const Vec3d an = vabs(n);
    const int drop = an.x >= an.y && an.x >= an.z ? 0 : (an.y >= an.z ? 1 : 2);
    const int u = (drop + 1) % 3, v = (drop + 2) % 3;
    auto edge = [&](const Vec3d& e0, const Vec3d& e1) {
      return sign_of((e1[u] - e0[u]) * (x[v] - e0[v]) - (e1[v] - e0[v]) * (x[u] - e0[u]));
    };
    const int e0 = edge(a, b), e1 = edge(b, c), e2 = edge(c, a);
    if ((e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0)) return true;
  }
  return false;
}

EmbreeScene::EmbreeScene(const TriangleSoup& soup, bool robust) : soup_(&soup) {
  for (const Vec3f& v : soup.vertices)
    if (!within_embree_bound(v)) {
      mesh_in_bound_ = false;  // every query goes to the fallback; no Embree scene
      return;
    }
  RTCDevice device = shared_device();
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
  scene_ = scene;
}

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
}

bool EmbreeScene::occluded(const Vec3f& from, const Vec3f& to) const {
  if (!mesh_in_bound_ || !within_embree_bound(from) || !within_embree_bound(to)) {
    fallback_rays_.fetch_add(1, std::memory_order_relaxed);
    return fallback_occluded(*soup_, from, to);
  }
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

void EmbreeScene::occluded_fan(const Vec3f& from, const Vec3f* to, int n, bool* out) const {
  if (n <= 0) return;
  if (n > 16) {
    occluded_fan(from, to, 16, out);
    occluded_fan(from, to + 16, n - 16, out + 16);
    return;
  }
  if (!mesh_in_bound_ || !within_embree_bound(from)) {
    for (int k = 0; k < n; ++k) out[k] = occluded(from, to[k]);
    return;
  }
  // A per-thread packet whose constant fields (tnear, time, mask, id, flags) are set
  // once; each call writes the origin, the directions, tfar and the lane mask.
  struct alignas(64) Packet {
    RTCRay16 ray;
    alignas(64) int valid[16];
    Packet() {
      for (int k = 0; k < 16; ++k) {
        ray.tnear[k] = 0.0f;
        ray.time[k] = 0.0f;
        ray.mask[k] = 0xFFFFFFFFu;
        ray.id[k] = unsigned(k);
        ray.flags[k] = 0;
        ray.dir_x[k] = ray.dir_y[k] = 0.0f;
        ray.dir_z[k] = 1.0f;  // inactive lanes keep a valid direction
      }
    }
  };
  thread_local Packet pk;
  RTCRay16& ray = pk.ray;
  int* valid = pk.valid;
  for (int k = 0; k < 16; ++k) {
    ray.org_x[k] = from.x;
    ray.org_y[k] = from.y;
    ray.org_z[k] = from.z;
    ray.tfar[k] = 1.0f;
    valid[k] = 0;
  }
  for (int k = 0; k < n; ++k) {
    if (!within_embree_bound(to[k])) continue;
    valid[k] = -1;
    Vec3f d = to[k] - from;
    ray.dir_x[k] = d.x;
    ray.dir_y[k] = d.y;
    ray.dir_z[k] = d.z;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcOccluded16(valid, static_cast<RTCScene>(scene_), &ctx, &ray);
  for (int k = 0; k < n; ++k)
    out[k] = valid[k] ? ray.tfar[k] == -std::numeric_limits<float>::infinity() : occluded(from, to[k]);
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
  result.stats.set("fallback_rays", double(es.fallback_rays()));
  return result;
}

}  // namespace visgate::raycast
