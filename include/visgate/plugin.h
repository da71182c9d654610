/* visgate plugin ABI, version 1 (DESIGN section 4, `--method plugin:PATH`).
 *
 * A visibility method in a shared library, run in-process by every visgate tool that
 * takes a method name (solve, check, gate, minimize, bench, render, fuzz_plugin). The
 * library exports one C function,
 *
 *     const visgate_method_v1_t* visgate_method_v1(void);
 *
 * returning a descriptor that lives as long as the library. visgate hands the method a
 * scene as flat arrays (visgate_scene_v1_t) and buffers it owns (visgate_output_v1_t); the
 * method fills one bit per relation. Plain C, no visgate headers or libraries needed.
 *
 * Relations. Receiver i and relation b (0 <= b < relations_per_receiver) are the segment
 * from receivers[i] to the light point relation_points[(i * relations_per_receiver + b)],
 * open at both ends. Relations are light-major: light l owns the relations
 * [light_offsets[l], light_offsets[l + 1]), one per sample. Bit b of receiver i is
 * visible_bits[i * words_per_receiver + b / 64] >> (b % 64) & 1: 1 when no triangle meets
 * the open segment (DESIGN section 3).
 *
 * Light points. relation_points is filled unless the descriptor sets
 * VISGATE_METHOD_NO_RELATION_POINTS; such a method rebuilds the points from the light
 * description (jitter points, jitter, seed: sample j of light l for receiver i is jitter
 * point relation_hash(i, j, seed) mod jitter of sample j, lib/scene/scene.h), for example
 * by building a visgate::Scene through include/visgate/visgate.h.
 *
 * Errors. solve returns 0 on success; otherwise non-zero with a one-line reason in
 * output->error. visgate reports it, a crash (a signal on the calling thread) or a
 * malformed answer as that method's failure (exit 3 naming it), disables a crashed
 * library for the rest of the process, and keeps every other method's results.
 *
 * Versioning. abi_version is VISGATE_METHOD_ABI_VERSION; visgate refuses a descriptor
 * with another version. Fields are only ever added at the end of a struct under a new
 * version; struct_size lets a reader see which fields exist.
 */
#ifndef VISGATE_PLUGIN_H
#define VISGATE_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VISGATE_METHOD_ABI_VERSION 1u

/* Sample patterns (DESIGN section 6); with EXPLICIT, jitter is 1 and the jitter points are
   the explicit samples. */
#define VISGATE_PATTERN_STRATIFIED 0u
#define VISGATE_PATTERN_RANDOM 1u
#define VISGATE_PATTERN_GRID 2u
#define VISGATE_PATTERN_EXPLICIT 3u

/* Descriptor flags. */
#define VISGATE_METHOD_NO_RELATION_POINTS 1u /* the method does not read relation_points */

typedef struct visgate_scene_v1_t {
  uint32_t struct_size; /* sizeof(visgate_scene_v1_t) */
  const char* name;     /* the scene's name (UTF-8, never NULL) */
  /* Blockers: one triangle soup. */
  const float* vertices;      /* vertex_count * 3 (x, y, z) */
  uint64_t vertex_count;
  const uint32_t* triangles;  /* triangle_count * 3 vertex indices */
  uint64_t triangle_count;
  /* Receivers. */
  const float* receiver_points;   /* receiver_count * 3 */
  const float* receiver_normals;  /* receiver_count * 3, unit */
  uint64_t receiver_count;
  /* Lights: polygons and samples. */
  uint64_t light_count;
  const uint64_t* light_polygon_offsets; /* light_count + 1 offsets into light_polygons (vertices) */
  const float* light_polygons;           /* vertices * 3, counter-clockwise seen from the lit side */
  const uint64_t* light_offsets;         /* light_count + 1: light l's relations [offsets[l], offsets[l+1]) */
  const uint32_t* light_jitter;          /* light_count: K jitter points per sample */
  const uint64_t* light_seed;            /* light_count */
  const uint32_t* light_pattern;         /* light_count: VISGATE_PATTERN_* (scene JSON "pattern") */
  const float* jitter_points;            /* per light l, samples(l) * K * 3, sample-major, lights in order */
  uint64_t relations_per_receiver;       /* light_offsets[light_count] */
  /* The light point of every relation, receiver-major: receiver_count *
     relations_per_receiver * 3; NULL with VISGATE_METHOD_NO_RELATION_POINTS. */
  const float* relation_points;
} visgate_scene_v1_t;

typedef struct visgate_option_v1_t {
  const char* key;
  const char* value;
} visgate_option_v1_t;

typedef struct visgate_output_v1_t {
  uint32_t struct_size;          /* sizeof(visgate_output_v1_t) */
  uint64_t* visible_bits;        /* receiver_count * words_per_receiver, zeroed by visgate */
  uint64_t words_per_receiver;   /* (relations_per_receiver + 63) / 64 */
  /* Optional: visible fraction per receiver and light (receiver_count * light_count),
     set to NaN by visgate; entries left NaN are computed from the bits. */
  float* visible_fraction;
  char* error;                   /* error_size bytes for a reason when solve fails */
  size_t error_size;
} visgate_output_v1_t;

typedef struct visgate_option_spec_v1_t {
  const char* name;
  const char* help;
  const char* values; /* allowed values separated by '|', or NULL: any non-negative integer */
} visgate_option_spec_v1_t;

typedef struct visgate_method_v1_t {
  uint32_t abi_version; /* VISGATE_METHOD_ABI_VERSION */
  uint32_t flags;       /* VISGATE_METHOD_* */
  const char* name;     /* short name for messages, e.g. "mt-caster" */
  /* Options the method accepts (`--opt key=value`), option_count entries (may be 0). */
  const visgate_option_spec_v1_t* options;
  size_t option_count;
  /* Optional (may be NULL): state for a series of solves with the same options, made once
     per solver object. Returns NULL and writes error on failure. */
  void* (*create)(const visgate_option_v1_t* options, size_t option_count, char* error, size_t error_size);
  /* Answers every relation of `scene`. `threads` 0 means all hardware threads. */
  int (*solve)(void* state, const visgate_scene_v1_t* scene, const visgate_option_v1_t* options, size_t option_count,
               uint64_t seed, int threads, visgate_output_v1_t* output);
  /* Optional: frees what create made (called once, when visgate drops the solver). */
  void (*free_state)(void* state);
} visgate_method_v1_t;

/* The one symbol a plugin exports. */
typedef const visgate_method_v1_t* (*visgate_method_v1_fn)(void);
#define VISGATE_METHOD_V1_SYMBOL "visgate_method_v1"

#ifdef __cplusplus
}
#endif

#endif /* VISGATE_PLUGIN_H */
