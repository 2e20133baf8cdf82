#include "sched/generate.h"

#include <algorithm>
#include <cmath>

namespace contego::sched {

Status validate(const GenOptions& o) {
  if (o.tasks < 1 || o.tasks > 10'000) return make_error("tasks must be between 1 and 10000");
  if (o.period_min <= 0 || o.period_max < o.period_min || o.period_max > kMaxDuration) {
    return make_error("periods: need 0 < min <= max");
  }
  if (o.period_granularity <= 0 || o.period_granularity > o.period_min) {
    return make_error("period granularity must be > 0 and at most the smallest period");
  }
  if (o.actuations_min < 0 || o.actuations_max < o.actuations_min || o.actuations_max > 1'000'000) {
    return make_error("actuations: need 0 <= min <= max");
  }
  return {};
}

std::vector<double> Generator::uunifast_discard(size_t n, double total) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> u(n);
  while (true) {
    double sum = total;
    bool ok = true;
    for (size_t i = 0; i + 1 < n; ++i) {
      const double next = sum * std::pow(unit(rng_), 1.0 / static_cast<double>(n - i - 1));
      u[i] = sum - next;
      sum = next;
      ok = ok && u[i] <= 1.0;
    }
    u[n - 1] = sum;
    if (ok && sum <= 1.0) return u;
  }
}

TaskSet Generator::generate(const GenOptions& o, double total) {
  TaskSet set;
  set.tasks.resize(o.tasks);
  const std::vector<double> u = uunifast_discard(o.tasks, total);
  const double log_min = std::log(static_cast<double>(o.period_min));
  const double log_max = std::log(static_cast<double>(o.period_max));
  std::uniform_real_distribution<double> log_period(log_min, log_max);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int64_t> checks(o.actuations_min, o.actuations_max);
  for (size_t i = 0; i < o.tasks; ++i) {
    Task& t = set.tasks[i];
    t.name = "t" + std::to_string(i + 1);
    const auto raw = static_cast<Nanos>(std::exp(log_period(rng_)));
    t.period = std::max(o.period_granularity, raw / o.period_granularity * o.period_granularity);
    t.wcet = std::clamp<Nanos>(std::llround(u[i] * static_cast<double>(t.period)), 1, t.period);
    t.deadline = t.period;
    if (o.constrained) {
      const double span = static_cast<double>(t.period - t.wcet);
      t.deadline = t.wcet + std::llround(unit(rng_) * span);
    }
    t.actuations = checks(rng_);
  }
  return set;
}

}  // namespace contego::sched
