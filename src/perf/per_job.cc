#include "perf/per_job.h"

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <fmt/core.h>
#include <fstream>
#include <optional>
#include <thread>

#include "perf/release.h"
#include "perf/rig.h"

namespace contego::perf {
namespace {

using namespace detail;

// The paths of the per-job bench, in slot order (a first: the baseline).
constexpr Path kPerJobPaths[] = {Path::kUnprotected, Path::kCore, Path::kSeccompInProcess,
                                 Path::kSeccompMonitor, Path::kPreload};

std::string joined_hex(const Workload& w) {
  std::string s;
  for (const auto& c : w.commands()) s += (s.empty() ? "" : ",") + hex(c);
  return s;
}

// The in-process paths (a, d): the same release grid as the task program's.
// `command` sends one command and says whether it failed. As the task
// program's, the samples end with the first job's release instant.
template <typename Send>
std::vector<uint64_t> time_jobs(const PerJobOptions& o, uint64_t grid_ns, Send command,
                                const std::function<void()>& anchor, uint64_t* failures) {
  const uint64_t period_ns = uint64_t{o.period_us} * 1000u;
  std::vector<uint64_t> ns(o.jobs);
  const uint64_t first = start_grid(grid_ns, period_ns);
  if (anchor) anchor();  // where the task program's first sleep is
  for (uint32_t j = 0; j < o.jobs; ++j) {
    sleep_until_ns(first + uint64_t{j} * period_ns);
    const uint64_t t0 = monotonic_ns();
    for (uint32_t i = 0; i < o.per_job; ++i) *failures += command(i) ? 1 : 0;
    ns[j] = monotonic_ns() - t0;
  }
  ns.push_back(first);
  return ns;
}

struct Lane {
  Path path;
  std::unique_ptr<Rig> rig;                 // a, d, c1
  std::unique_ptr<MonitorProcess> process;  // c2, b
  std::string audit, out;
  PerJobRow row;
  Result<std::vector<uint64_t>> samples = std::vector<uint64_t>{};
};

void run_lane(const PerJobOptions& o, Lane& lane, uint64_t grid_ns) {
  const Workload& w = o.workload;
  const std::vector<std::string> argv = {o.task_exe,
                                         "/dev/i2c-1",
                                         fmt::format("0x{:02x}", w.addr),
                                         joined_hex(w),
                                         std::to_string(o.jobs),
                                         lane.out,
                                         std::to_string(o.period_us),
                                         std::to_string(o.per_job),
                                         std::to_string(grid_ns)};
  const auto job = w.commands();
  switch (lane.path) {
    case Path::kUnprotected: {
      bus::Bus& bus = lane.rig->bus;
      lane.samples = time_jobs(
          o, grid_ns,
          [&](uint32_t i) {
            std::vector<uint8_t> buf = job[i % job.size()];
            bus::Msg m{w.addr, 0, static_cast<uint16_t>(buf.size()), buf.data()};
            return bus.transfer({&m, 1}) != 0;
          },
          {}, &lane.row.failures);
      break;
    }
    case Path::kCore: {
      std::vector<gate::Transfer> transfers;
      for (const auto& bytes : job) {
        gate::Transfer t;
        t.bus = 1;
        t.messages.push_back(gate::Message{w.addr, 0, static_cast<uint16_t>(bytes.size()), bytes});
        transfers.push_back(t);
      }
      monitor::Monitor& mon = *lane.rig->mon;
      lane.samples = time_jobs(
          o, grid_ns,
          [&](uint32_t i) {
            return mon.transfer(w.task_id, transfers[i % transfers.size()]).err != 0;
          },
          [&] { mon.job_boundary(w.task_id); }, &lane.row.failures);
      break;
    }
    case Path::kSeccompInProcess:
      lane.samples = run_seccomp(argv, *lane.rig->mon, w.task_id, &lane.row.failures, o.cpu);
      break;
    case Path::kSeccompMonitor: {
      Transport how;
      how.spin_us = o.spin_us;
      how.cpu = o.cpu;
      lane.samples = run_over_socket(lane.process->socket(), w, argv, &lane.row.failures, how);
      break;
    }
    default:
      lane.samples = run_preload(o.preload_lib, o.spin_us, lane.process->socket(), w, argv,
                                 &lane.row.failures, true, o.cpu);
      break;
  }
}

}  // namespace

const PerJobRow* PerJobReport::find(Path p) const {
  for (const PerJobRow& r : rows) {
    if (r.path == p) return &r;
  }
  return nullptr;
}

Result<PerJobReport> run_per_job(const PerJobOptions& o) {
  if (o.jobs == 0 || o.per_job == 0 || o.period_us < 1000) {
    return make_error(
        "the per-job bench needs at least 1 job, 1 command per job and a period of 1 ms");
  }
  if (Status s = check_cpu(o.cpu); !s.ok()) return make_error(s.error());
  if (access(o.task_exe.c_str(), X_OK) != 0) {
    return make_error("cannot execute the bench task program " + o.task_exe);
  }
  TempDir dir;
  if (dir.path.empty()) return make_error(std::string("mkdtemp: ") + strerror(errno));
  auto say = [&](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  // Monitor processes first (forked before any thread), then the local rigs.
  std::vector<Lane> lanes;
  for (Path p : kPerJobPaths) {
    if (p == Path::kPreload && o.preload_lib.empty()) continue;
    Lane lane;
    lane.path = p;
    lane.out = fmt::format("{}/jobs-{}.bin", dir.path, static_cast<int>(p));
    if (is_remote(p)) {
      lane.process = std::make_unique<MonitorProcess>();
      if (Status s = lane.process->start(dir.path, fmt::format("monitor-{}", static_cast<int>(p)),
                                         o.workload, o.spin_us);
          !s.ok()) {
        return make_error(s.error());
      }
      lane.audit = lane.process->audit();
    }
    lanes.push_back(std::move(lane));
  }
  for (Lane& lane : lanes) {
    if (lane.process) continue;
    lane.audit = fmt::format("{}/local-{}-audit.jsonl", dir.path, static_cast<int>(lane.path));
    auto rig = Rig::make(lane.audit, o.workload);
    if (!rig.ok()) return make_error(rig.error());
    lane.rig = std::move(*rig);
    lane.rig->start();
  }
  const uint64_t period_ns = uint64_t{o.period_us} * 1000u;
  const uint64_t slot_ns = period_ns / lanes.size();
  // A second for every task program to start and connect.
  const uint64_t grid = monotonic_ns() + 1000000000u;
  say(fmt::format("per job: {} jobs of {} commands every {} us on {} paths, interleaved ({:.0f} s)",
                  o.jobs, o.per_job, o.period_us, lanes.size(),
                  static_cast<double>(uint64_t{o.jobs} * period_ns) / 1e9 + 1));
  std::vector<std::thread> threads;
  for (size_t i = 0; i < lanes.size(); ++i) {
    threads.emplace_back([&, i] { run_lane(o, lanes[i], grid + i * slot_ns); });
  }
  for (std::thread& t : threads) t.join();

  PerJobReport report;
  report.workload = o.workload.name;
  report.jobs = o.jobs;
  report.period_us = o.period_us;
  report.per_job = o.per_job;
  report.cpu = o.cpu;
  for (Lane& lane : lanes) {
    if (!lane.samples.ok()) {
      return make_error(
          fmt::format("per job / {}: {}", path_label(lane.path), lane.samples.error()));
    }
    // Every job's time, then the first job's release instant.
    if (lane.samples->size() != uint64_t{o.jobs} + 1) {
      return make_error(
          fmt::format("per job / {}: {} values from the task, expected {} jobs' times and "
                      "the first release",
                      path_label(lane.path), lane.samples->size(), o.jobs));
    }
    PerJobRow& row = lane.row;
    row.path = lane.path;
    if (lane.path != Path::kUnprotected) row.decisions = decisions_in(lane.audit);
    const uint64_t first_release = lane.samples->back();
    lane.samples->pop_back();
    row.slowest = slowest_jobs(*lane.samples, first_release, period_ns, kSlowestKept);
    row.job_ns = std::move(*lane.samples);
    std::sort(row.job_ns.begin(), row.job_ns.end());
    row.stats = summarise(row.job_ns);
    say(fmt::format("per job / {}: median {:.2f} us, p99 {:.2f} us per job", path_label(row.path),
                    row.stats.median_us, row.stats.p99_us));
    report.rows.push_back(std::move(row));
  }
  return report;
}

namespace {

// "c2" of "c2 seccomp+monitor".
std::string path_code(Path p) {
  const std::string label = path_label(p);
  return label.substr(0, label.find(' '));
}

}  // namespace

std::vector<SlowJob> slowest_jobs(const std::vector<uint64_t>& job_ns, uint64_t first_release_ns,
                                  uint64_t period_ns, size_t count) {
  std::vector<uint32_t> order(job_ns.size());
  for (uint32_t j = 0; j < order.size(); ++j) order[j] = j;
  const size_t kept = std::min(count, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(kept), order.end(),
                    [&](uint32_t a, uint32_t b) {
                      return job_ns[a] != job_ns[b] ? job_ns[a] > job_ns[b] : a < b;
                    });
  std::vector<SlowJob> slowest;
  for (size_t k = 0; k < kept; ++k) {
    const uint32_t j = order[k];
    slowest.push_back({j, first_release_ns + uint64_t{j} * period_ns, job_ns[j]});
  }
  return slowest;
}

std::string per_job_table(const PerJobReport& r) {
  std::string s = fmt::format(
      "contego bench --per-job: {}, {} jobs of {} commands every {} us, all paths interleaved;\n"
      "CLOCK_MONOTONIC from each job's wake-up to the end of its last write()\n{}\n",
      r.workload, r.jobs, r.per_job, r.period_us, detail::pinning_line(r.cpu));
  s += fmt::format("{:<20} {:>9} {:>9} {:>9} {:>10}   {:>9} {:>9} {:>10}   {}\n", "path", "avg",
                   "median", "p99", "worst", "+avg", "+p99", "+worst", "decisions (audit log)");
  s += fmt::format("{:<20} {:>9} {:>9} {:>9} {:>10}   {:>9} {:>9} {:>10}\n", "", "µs", "µs", "µs",
                   "µs", "µs", "µs", "µs");
  const PerJobRow* base = r.find(Path::kUnprotected);
  for (const PerJobRow& row : r.rows) {
    const Stats& x = row.stats;
    s += fmt::format("{:<20} {:>9.2f} {:>9.2f} {:>9.2f} {:>10.2f}", path_label(row.path), x.mean_us,
                     x.median_us, x.p99_us, x.worst_us);
    if (row.path == Path::kUnprotected || base == nullptr) {
      s += "   (baseline, not checked)";
    } else {
      const Stats& b = base->stats;
      s += fmt::format("   {:>9.2f} {:>9.2f} {:>10.2f}  ", x.mean_us - b.mean_us,
                       x.p99_us - b.p99_us, x.worst_us - b.worst_us);
      for (const auto& [decision, count] : row.decisions)
        s += fmt::format(" {} {}", decision, count);
    }
    if (row.failures != 0) s += "  (some commands failed)";
    s += "\n";
  }
  const PaperFigures paper;
  const auto range = [](const double(&ms)[2]) {
    return fmt::format("{:.0f}-{:.0f}", ms[0] * 1000, ms[1] * 1000);
  };
  s += fmt::format(
      "paper (Contego-TEE), added per job of its rover control tasks, range over the tasks: "
      "+avg {} +p99 {} +worst {} µs ({} ms period, {} trials)\n",
      range(paper.avg_ms), range(paper.p99_ms), range(paper.worst_ms), paper.period_ms,
      paper.trials);
  // When to look in a trace (`perf record -k CLOCK_MONOTONIC`) for what
  // else ran during a path's worst job.
  std::string slowest;
  for (const PerJobRow& row : r.rows) {
    if (row.path == Path::kUnprotected || row.slowest.empty()) continue;
    const SlowJob& w = row.slowest.front();
    slowest += fmt::format("{}{} {:.0f} µs at {}.{:09}", slowest.empty() ? "" : ", ",
                           path_code(row.path), static_cast<double>(w.job_ns) / 1000.0,
                           w.release_ns / 1000000000u, w.release_ns % 1000000000u);
  }
  if (!slowest.empty()) {
    s += fmt::format(
        "slowest job, released at (CLOCK_MONOTONIC s): {}; the {} slowest of each "
        "path are in per-job.json\n",
        slowest, kSlowestKept);
  }
  return s;
}

nlohmann::json per_job_json(const PerJobReport& r) {
  const PaperFigures paper;
  nlohmann::json j = {{"workload", r.workload},
                      {"jobs", r.jobs},
                      {"period_us", r.period_us},
                      {"commands_per_job", r.per_job},
                      {"task_cpu", r.cpu},
                      {"paper_added_ms",
                       {{"avg", paper.avg_ms},
                        {"p99", paper.p99_ms},
                        {"worst", paper.worst_ms},
                        {"period_ms", paper.period_ms},
                        {"trials", paper.trials}}}};
  const PerJobRow* base = r.find(Path::kUnprotected);
  nlohmann::json paths = nlohmann::json::object();
  for (const PerJobRow& row : r.rows) {
    const Stats& x = row.stats;
    nlohmann::json cell = {{"label", path_label(row.path)},
                           {"job_us",
                            {{"avg", x.mean_us},
                             {"median", x.median_us},
                             {"p99", x.p99_us},
                             {"p999", x.p999_us},
                             {"worst", x.worst_us}}},
                           {"failures", row.failures}};
    if (row.path != Path::kUnprotected && base != nullptr) {
      const Stats& b = base->stats;
      cell["added_us"] = {{"avg", x.mean_us - b.mean_us},
                          {"p99", x.p99_us - b.p99_us},
                          {"worst", x.worst_us - b.worst_us}};
      cell["decisions"] = row.decisions;
    }
    nlohmann::json slowest = nlohmann::json::array();
    for (const SlowJob& w : row.slowest) {
      slowest.push_back({{"job", w.job},
                         {"release_ns", w.release_ns},
                         {"job_us", static_cast<double>(w.job_ns) / 1000.0}});
    }
    cell["slowest"] = slowest;
    paths[path_key(row.path)] = cell;
  }
  j["paths"] = paths;
  return j;
}

namespace {

bool on_path(const std::string& program) {
  const char* path = getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  size_t at = 0;
  while (at <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', at), dirs.size());
    const std::string dir = dirs.substr(at, end - at);
    if (!dir.empty() && access((dir + "/" + program).c_str(), X_OK) == 0) return true;
    at = end + 1;
  }
  return false;
}

}  // namespace

Result<std::string> write_per_job_cdf(const PerJobReport& r, const std::string& stem) {
  const std::string dat = stem + ".dat", gp = stem + ".gp";
  {
    std::ofstream d(dat);
    d << "# job_us cumulative_fraction; one block per path (gnuplot index), path a first\n";
    for (const PerJobRow& row : r.rows) {
      d << "# " << path_label(row.path) << "\n";
      const size_t n = row.job_ns.size();
      for (size_t i = 0; i < n; ++i) {
        d << fmt::format("{:.3f} {:.6f}\n", static_cast<double>(row.job_ns[i]) / 1000.0,
                         static_cast<double>(i + 1) / static_cast<double>(n));
      }
      d << "\n\n";
    }
    if (!d) return make_error("cannot write " + dat);
  }
  {
    std::ofstream g(gp);
    for (const auto& [term, out] :
         {std::pair<std::string, std::string>{"svg size 1000,600 dynamic", stem + ".svg"},
          {"pngcairo size 1000,600", stem + ".png"}}) {
      g << "set terminal " << term << "\nset output '" << out << "'\n"
        << "set title 'contego: time per job, " << r.jobs << " jobs of " << r.per_job
        << " commands every " << r.period_us << " us (CDF)'\n"
        << "set xlabel 'job time, microseconds (log scale)'\nset ylabel 'fraction of jobs'\n"
        << "set logscale x\nset yrange [0:1.02]\nset grid\nset key bottom right\nplot ";
      for (size_t i = 0; i < r.rows.size(); ++i) {
        g << (i == 0 ? "" : ", \\\n  ") << "'" << dat << "' index " << i
          << " using 1:2 with steps lw 2 title '" << path_label(r.rows[i].path) << "'";
      }
      g << "\n";
    }
    if (!g) return make_error("cannot write " + gp);
  }
  if (!on_path("gnuplot")) {
    return "gnuplot not found: no plot drawn (the CDF's data is in " + dat + ", its script in " +
           gp + ")";
  }
  if (system(("gnuplot '" + gp + "' 2>&1").c_str()) != 0) {
    return make_error("gnuplot failed on " + gp);
  }
  return "wrote " + stem + ".svg and " + stem + ".png (CDF; data " + dat + ")";
}

}  // namespace contego::perf
