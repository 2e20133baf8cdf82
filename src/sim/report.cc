#include "sim/report.h"

#include <spawn.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sys/wait.h>

#include "contego/core/checker.h"

#include "sim/settings.h"

extern char** environ;

namespace contego::sim {
namespace {

std::string num(double v) {
  if (v == 0.0) return "0";  // avoid "-0.0000"
  return fmt::format("{:.4f}", v);
}

std::string hex(const std::vector<uint8_t>& bytes) {
  std::string s;
  for (size_t i = 0; i < bytes.size(); ++i) s += fmt::format("{}{:02x}", i ? " " : "", bytes[i]);
  return s;
}

// A gnuplot string literal.
std::string quote(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '\n') {  // a line break, as gnuplot reads it
      q += "\\n";
      continue;
    }
    if (c == '"' || c == '\\') q += '\\';
    q += c;
  }
  return q + "\"";
}

size_t column_index(const RunResult& run, const std::string& name) {
  auto it = std::find(run.columns.begin(), run.columns.end(), name);
  return it == run.columns.end() ? 0 : static_cast<size_t>(it - run.columns.begin()) + 1;
}

struct Panel {
  std::string column;
  std::string ylabel;
};

struct Style {
  const char* label;
  const char* title;
  const char* color;
  const char* dash;
};
// The attack-free reference is drawn last, dashed, so it shows on top of a
// protected run that coincides with it.
constexpr Style kStyles[] = {
    {"unprotected", "attack, contego off", "#800000", "lw 2 dt 1"},
    {"protected", "attack, contego on", "#1a9641", "lw 2 dt 1"},
    {"baseline", "no attack, contego on", "#303030", "lw 1.2 dt (6,4)"},
};

std::string shade_windows(const Scenario& sc, double scale) {
  std::string s;
  int n = 1;
  for (const auto& a : sc.attacks) {
    s += fmt::format(
        "set object {} rect from {}, graph 0 to {}, graph 1 behind fc rgb '#e6e6e6' "
        "fs solid 1.0 noborder\n",
        n++, num(static_cast<double>(a.start_us) * 1e-6 * scale),
        num(static_cast<double>(a.end_us) * 1e-6 * scale));
  }
  return s;
}

// The x axis of a time series: time in seconds divided by `unit_s`.
struct XAxis {
  double unit_s;
  std::string label;
  std::string note = {};  // a second line under the last panel's x label
};

std::string time_series_body(const Scenario& sc, const std::vector<RunResult>& runs,
                             const std::string& dir, const std::string& stem,
                             const std::vector<Panel>& panels, const XAxis& x) {
  std::string b;
  const double scale = 1.0 / x.unit_s;
  const std::string xexpr = x.unit_s == 1.0 ? "1" : fmt::format("($1/{})", num(x.unit_s));
  const std::string& xlabel = x.label;
  b += fmt::format("set multiplot layout {},1 title {}\n", panels.size(), quote(sc.title));
  for (const auto& p : panels) {
    b += "unset object\n" + shade_windows(sc, scale);
    const bool last = &p == &panels.back();
    b += fmt::format("set xlabel {}\nset ylabel {}\n",
                     quote(last && !x.note.empty() ? xlabel + "\n" + x.note : xlabel),
                     quote(p.ylabel));
    std::string plot = "plot NaN with boxes fs solid 1.0 fc rgb '#e6e6e6' title 'attack window'";
    for (const auto& st : kStyles) {
      for (const auto& run : runs) {
        if (run.label != st.label) continue;
        const size_t c = column_index(run, p.column);
        if (c == 0) continue;
        plot += fmt::format(", {} skip 1 using {}:{} with lines lc rgb '{}' {} title {}",
                            quote(dir + "/" + stem + "-" + run.label + ".csv"), xexpr, c, st.color,
                            st.dash, quote(st.title));
      }
    }
    b += plot + "\n";
  }
  b += "unset multiplot\n";
  return b;
}

// The paper's Fig. 1: gripper pulses by access number, unprotected on top,
// protected below, the accesses made during the attack shaded.
std::string fig1_body(const Scenario& sc, const std::vector<RunResult>& runs,
                      const std::string& dir, const std::string& stem) {
  // One y range for both panels, so that their pulses compare at a glance.
  double top = 600;
  for (const auto& r : runs) {
    for (const auto& e : r.events) top = std::max(top, e.value);
  }
  // The labels are the arm code's (docs/simulation.md, "Arm"): said on the
  // figure, since the paper's text names the two levels the other way round.
  size_t accesses = 0;
  for (const auto& r : runs) accesses = std::max(accesses, r.events.size());
  std::string b = fmt::format(
      "set multiplot layout 2,1 title {}\nset key outside right top vertical\nset xrange [0:{}]\n",
      quote(sc.title), accesses + 1);
  for (const char* label : {"unprotected", "protected"}) {
    const RunResult* run = nullptr;
    for (const auto& r : runs) {
      if (r.label == label) run = &r;
    }
    if (!run) continue;
    b += "unset object\n";
    int first = -1, last = -1;
    for (size_t i = 0; i < run->events.size(); ++i) {
      for (const auto& a : sc.attacks) {
        if (a.active(run->events[i].time_us)) {
          if (first < 0) first = static_cast<int>(i) + 1;
          last = static_cast<int>(i) + 1;
        }
      }
    }
    if (first > 0) {
      b += fmt::format(
          "set object 1 rect from {}, graph 0 to {}, graph 1 behind fc rgb '#e6e6e6' "
          "fs solid 1.0 noborder\n",
          first - 0.5, last + 0.5);
    }
    const bool on = std::string(label) == "protected";
    const std::string xlabel = on ? "gripper (channel 5) access number\nopen 420, close 577 as the "
                                    "arm code sends them; the paper's text swaps the two names"
                                  : "gripper (channel 5) access number";
    b += fmt::format("set xlabel {}\nset ylabel 'pulse (PCA9685 ticks)'\n", quote(xlabel));
    b += fmt::format("set yrange [0:{}]\n", num(top * 1.05));
    b += fmt::format(
        "plot NaN with boxes fs solid 1.0 fc rgb '#e6e6e6' title 'attack window', "
        "{} skip 1 using ($0+1):3 with linespoints pt 7 ps 0.6 lw 1.5 lc rgb '{}' title {}, "
        "420 with lines dt 3 lc rgb '#555555' title 'open (420)', "
        "577 with lines dt 2 lc rgb '#555555' title 'close (577)'\n",
        quote(dir + "/" + stem + "-" + label + "-events.csv"), on ? "#1a9641" : "#800000",
        quote(on ? "contego on" : "contego off"));
  }
  b += "unset multiplot\nset xrange [*:*]\nset yrange [*:*]\nset key inside top left vertical\n";
  return b;
}

Status run_gnuplot(const std::string& script) {
  const char* argv[] = {"gnuplot", script.c_str(), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "gnuplot", nullptr, nullptr, const_cast<char**>(argv), environ);
  if (rc != 0) return make_error(fmt::format("cannot start gnuplot: {}", std::strerror(rc)));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return make_error("waitpid on gnuplot failed");
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return make_error(fmt::format("gnuplot failed on {}", script));
  }
  return {};
}

}  // namespace

std::string trace_csv(const RunResult& run) {
  std::string out;
  for (size_t i = 0; i < run.columns.size(); ++i) out += (i ? "," : "") + run.columns[i];
  out += "\n";
  for (const auto& row : run.rows) {
    for (size_t i = 0; i < row.size(); ++i) {
      out += i ? "," : "";
      out += num(row[i]);
    }
    out += "\n";
  }
  return out;
}

std::string events_csv(const RunResult& run) {
  std::string out = "time_s,event,value\n";
  for (const auto& e : run.events) {
    out +=
        fmt::format("{},{},{}\n", num(static_cast<double>(e.time_us) * 1e-6), e.what, num(e.value));
  }
  return out;
}

std::string ops_csv(const RunResult& run) {
  std::string out = "time_s,task,addr,op,bytes,injected,decision,reason,emitted\n";
  for (const auto& o : run.ops) {
    std::string emitted;
    for (const auto& e : o.emitted) emitted += (emitted.empty() ? "" : " | ") + hex(e);
    out += fmt::format("{},{},0x{:02x},{},{},{},{},{},{}\n",
                       num(static_cast<double>(o.time_us) * 1e-6), o.task, o.addr,
                       o.read ? "read" : "write", hex(o.bytes), o.injected ? 1 : 0,
                       core::decision_name(o.decision), static_cast<int>(o.reason), emitted);
  }
  return out;
}

Status write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return make_error(path + ": cannot open for writing");
  f << text;
  f.close();
  if (!f) return make_error(path + ": write failed");
  return {};
}

Result<std::vector<std::string>> write_traces(const std::vector<RunResult>& runs,
                                              const std::string& dir, const std::string& stem) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return make_error(dir + ": cannot create directory: " + ec.message());
  std::vector<std::string> written;
  for (const auto& run : runs) {
    const std::string base = dir + "/" + stem + "-" + run.label;
    for (const auto& [path, text] : {std::pair{base + ".csv", trace_csv(run)},
                                     std::pair{base + "-events.csv", events_csv(run)},
                                     std::pair{base + "-ops.csv", ops_csv(run)}}) {
      auto st = write_file(path, text);
      if (!st) return make_error(st.error());
      written.push_back(path);
    }
  }
  return written;
}

Result<std::vector<std::string>> plot_runs(const Scenario& sc, const std::vector<RunResult>& runs,
                                           const std::string& dir, const std::string& stem,
                                           const std::string& figure) {
  std::string fig = figure;
  if (fig == "auto") fig = sc.platform == "arm" ? "fig1" : sc.platform;
  const double period_s =
      static_cast<double>(setting_duration_us(sc.settings, "period", 200'000)) * 1e-6;
  std::string body;
  int height = 700;
  const XAxis jobs{period_s, fmt::format("controller job ({:g} ms period)", period_s * 1000.0)};
  const XAxis seconds{1.0, "time (s)"};
  if (fig == "fig1") {
    body = fig1_body(sc, runs, dir, stem);
  } else if (fig == "fig4a") {
    body = time_series_body(sc, runs, dir, stem,
                            {{"distance_cm", "distance travelled (cm, from the encoders)"}}, jobs);
    height = 450;
  } else if (fig == "fig4b" || fig == "rover") {
    // Said on the figure: a reader takes the protected run's lower speed
    // inside the attack window for the attack's doing; it is the track's bend
    // (docs/simulation.md), which the attack-free run takes at the same speed.
    XAxis x = jobs;
    x.note =
        "contego on keeps to the attack-free run (dashed, on top): its lower speed from job 60 "
        "on is the track's bend";
    body = time_series_body(sc, runs, dir, stem,
                            {{"distance_cm", "distance travelled (cm, from the encoders)"},
                             {"speed_cm_s", "speed (cm/s, encoders, 1 s window)"}},
                            x);
  } else if (fig == "tank") {
    body = time_series_body(
        sc, runs, dir, stem,
        {{"level_mm", "water level (mm; alarm above 800)"}, {"buzzer", "buzzer (1 = sounding)"}},
        seconds);
  } else if (fig == "pump") {
    body = time_series_body(
        sc, runs, dir, stem,
        {{"delivered_ul", "volume delivered (uL)"}, {"rate_ul_h", "pump rate (uL/h)"}},
        XAxis{3600.0, "time (h)"});
  } else if (fig == "camera") {
    body = time_series_body(
        sc, runs, dir, stem,
        {{"pan_deg", "pan angle (deg; allowed -60..60)"}, {"siren", "siren (1 = sounding)"}},
        seconds);
  } else {
    return make_error("no figure layout '" + fig + "'");
  }
  const std::string out = dir + "/" + stem;
  std::string script =
      "# generated by contego sim\nset datafile separator ','\nset grid\nset key top left "
      "box opaque\nset style fill solid 1.0\n";
  script += fmt::format("set terminal svg size 1000,{} dynamic enhanced font 'sans,12'\n", height);
  script += fmt::format("set output {}\n", quote(out + ".svg")) + body;
  script += fmt::format("set terminal pngcairo size 1000,{} enhanced font 'sans,11'\n", height);
  script += fmt::format("set output {}\n", quote(out + ".png")) + body;
  script += "set output\n";
  auto st = write_file(out + ".gp", script);
  if (!st) return make_error(st.error());
  auto gp = run_gnuplot(out + ".gp");
  if (!gp) return make_error(gp.error());
  return std::vector<std::string>{out + ".svg", out + ".png"};
}

std::string summary_table(const Scenario& sc, const std::vector<RunResult>& runs) {
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> head{"measure"};
  for (const auto& r : runs) head.push_back(r.label);
  rows.push_back(head);
  auto add = [&](const std::string& name, auto value_of) {
    std::vector<std::string> row{name};
    for (const auto& r : runs) row.push_back(value_of(r));
    rows.push_back(row);
  };
  if (!runs.empty()) {
    for (size_t m = 0; m < runs[0].metrics.size(); ++m) {
      const auto& first = runs[0].metrics[m];
      add(first.unit.empty() ? first.name : first.name + " (" + first.unit + ")",
          [&](const RunResult& r) {
            return m < r.metrics.size() ? fmt::format("{:.1f}", r.metrics[m].value) : "-";
          });
    }
  }
  add("commands sent", [](const RunResult& r) { return std::to_string(r.stats.writes); });
  add("  of which injected", [](const RunResult& r) { return std::to_string(r.stats.injected); });
  add("  allowed", [](const RunResult& r) { return std::to_string(r.stats.allowed); });
  add("  ignored", [](const RunResult& r) { return std::to_string(r.stats.ignored); });
  add("  replaced (fail-safe)",
      [](const RunResult& r) { return std::to_string(r.stats.replaced); });
  add("  rejected", [](const RunResult& r) { return std::to_string(r.stats.rejected); });
  add("violations seen", [](const RunResult& r) { return std::to_string(r.stats.violations); });
  add("first violation (s)", [](const RunResult& r) {
    return r.stats.first_violation_us
               ? fmt::format("{:.3f}", static_cast<double>(*r.stats.first_violation_us) * 1e-6)
               : std::string("-");
  });
  std::vector<size_t> width(head.size(), 0);
  for (const auto& row : rows) {
    for (size_t i = 0; i < row.size(); ++i) width[i] = std::max(width[i], row[i].size());
  }
  std::string out = fmt::format("{} ({})\n", sc.title, sc.name);
  for (size_t r = 0; r < rows.size(); ++r) {
    for (size_t i = 0; i < rows[r].size(); ++i) {
      out += i == 0 ? fmt::format("  {:<{}}", rows[r][i], width[i])
                    : fmt::format("  {:>{}}", rows[r][i], width[i]);
    }
    out += "\n";
    if (r == 0) {
      size_t total = 0;
      for (auto w : width) total += w + 2;
      out += "  " + std::string(total - 2, '-') + "\n";
    }
  }
  return out;
}

bool gnuplot_available() {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = end > start ? dirs.substr(start, end - start) : ".";
    if (access((dir + "/gnuplot").c_str(), X_OK) == 0) return true;
    start = end + 1;
  }
  return false;
}

}  // namespace contego::sim
