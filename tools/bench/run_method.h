// Helpers the experiments share to measure a method on a scene and tabulate its stats.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "tools/bench/bench.h"

namespace visgate::bench {

// Measures `method` on `scene` (min of --repeat runs, 1 thread and all threads) with
// the given method options. With a guard, a point predicted to exceed the budget is
// skipped (noted) and nullopt returned; the guard records every measured point. Shows
// `label` as progress. nullopt (noted) also when the method is not registered or
// rejects the options. `config`: how to measure instead of ctx.measure_config() (e.g.
// single-threaded runs only).
std::optional<Measured> run_method(BenchContext& ctx, const std::string& method, const Scene& scene,
                                   const std::string& label, SweepGuard* guard = nullptr, double size = 0.0,
                                   const std::map<std::string, std::string>& opts = {},
                                   const MeasureConfig* config = nullptr);

// The options of a bench run of `solver`: --seed, `opts`, --memory-budget; nullopt, noted
// "<method> at <label>: <why>: skipped", when the method refuses them.
std::optional<SolveOptions> checked_options(BenchContext& ctx, const Solver& solver, const std::string& method,
                                            const std::map<std::string, std::string>& opts, const std::string& label);

// Share of blocked relations in a bit result (0..1).
double blocked_share(const Scene& scene, const SolveResult& r);

// Appends one row per stat of `stats` to a long-format table whose first columns are
// `prefix` and whose last two are "stat" and "value".
void add_stat_rows(Table& t, const std::vector<Json>& prefix, const Stats& stats);

// "NaN" safe ratio a / b (NaN when either is missing or b is 0).
double ratio(double a, double b);

// A result's visible fractions, receiver-major, one per (receiver, light) of `s` (0 where
// the result has none).
std::vector<double> method_fractions(const Scene& s, const SolveResult& r);

// Relations `method` answered by plain rays (segment tests) rather than by its own
// structure, in percent (`ray_pct`), and the percent its structure decided: iss leaf and
// automatic rays, ssv fallback relations, plucker-bsp segment relations; every relation
// for the ray casters (experiments_paper.cpp).
void ray_cast_shares(const std::string& method, const Stats& st, double relations, double& ray_pct,
                     double& decided_pct);

// The method's own count of its structures' peak in MB (stat peak_memory_kb, else
// peak_memory_mb or memory_mb), NaN when it reports none.
double method_peak_mb(const Stats& st);

// Root mean square error of the visible fraction over the penumbra pairs: (receiver,
// light) pairs whose exact fraction is strictly between 0.001 and 0.999. `count`
// receives their number. NaN when there is none (experiments_oracle.cpp).
double penumbra_rms(const std::vector<double>& got, const std::vector<double>& exact, size_t* count);

}  // namespace visgate::bench
