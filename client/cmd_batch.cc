// `shrm batch MANIFEST.json`: every map of a manifest with every BRDF, as `shrm prefilter` jobs
// run concurrently (embedded or on shrmd), resumable: an output whose header records the same
// job parameters and source SHA-256 is skipped (docs/cli.md).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "client/cli_common.h"
#include "client/commands.h"
#include "client/prefilter_job.h"
#include "core/brdf/brdf.h"
#include "core/shrm/shrm_file.h"

namespace shrm::cli {
namespace {

namespace fs = std::filesystem;

struct BatchArgs {
  std::string manifest;
  int jobs = 1;
  int threads = 0;
  std::string server;
  bool force = false;
  bool json = false;
};

struct BatchOptions {
  double epsilon = 0.03;
  std::string kind = "global";
  int size = 0;
  std::string orders;  // "F,P", normalized
  bool half = false;
  std::vector<double> rotate;
  bool report = false;
  bool preview = false;
};

struct Job {
  int index = 0;
  std::string map;        // as resolved (manifest folder / entry)
  std::string map_entry;  // as written in the manifest
  std::string brdf;       // as written
  std::string canonical_brdf;
  std::string output, report, preview;
  // Outcome.
  std::string status = "pending";  // ok, skipped, failed
  std::string orders;
  double seconds = 0;
  int retries = 0;  // remote: attempts beyond the first
  std::string message;
};

// {brdf}: the spec with every character outside [A-Za-z0-9_.-] replaced by '_'.
std::string SanitizeSpec(const std::string& spec) {
  std::string s = spec;
  for (char& c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-')) c = '_';
  }
  return s;
}

// The output path without ".shrm.exr" (or ".exr"), for the report and preview names.
std::string OutputStem(const std::string& output) {
  for (const char* suffix : {".shrm.exr", ".exr"}) {
    const std::string suf = suffix;
    if (output.size() > suf.size() &&
        output.compare(output.size() - suf.size(), suf.size(), suf) == 0)
      return output.substr(0, output.size() - suf.size());
  }
  return output;
}

std::string Resolve(const fs::path& dir, const std::string& entry) {
  const fs::path p(entry);
  if (p.is_absolute() || dir.empty()) return p.lexically_normal().string();
  return (dir / p).lexically_normal().string();
}

// Reads and validates the manifest; every problem is appended to *errors with its JSON path.
void ParseManifest(const nlohmann::json& m, const fs::path& dir, BatchOptions* opt,
                   std::vector<Job>* jobs, std::vector<std::string>* errors) {
  auto err = [&](const std::string& path, const std::string& what) {
    errors->push_back(absl::StrCat(path, ": ", what));
  };
  if (!m.is_object()) {
    err("$", "the manifest must be a JSON object");
    return;
  }
  for (const auto& [key, value] : m.items()) {
    if (key != "maps" && key != "brdfs" && key != "options" && key != "output")
      err("$." + key, "unknown key (expected maps, brdfs, options, output)");
  }
  std::vector<std::string> maps, brdfs, canonical;
  auto string_list = [&](const char* key, std::vector<std::string>* out) {
    const std::string path = absl::StrCat("$.", key);
    if (!m.contains(key)) return err(path, "missing (a non-empty array of strings)");
    const nlohmann::json& a = m.at(key);
    if (!a.is_array() || a.empty()) return err(path, "must be a non-empty array of strings");
    for (size_t i = 0; i < a.size(); ++i) {
      if (!a[i].is_string()) {
        err(absl::StrCat(path, "[", i, "]"), "must be a string");
        out->push_back("");
      } else {
        out->push_back(a[i].get<std::string>());
      }
    }
  };
  string_list("maps", &maps);
  string_list("brdfs", &brdfs);
  std::vector<bool> map_ok(maps.size(), false), brdf_ok(brdfs.size(), false);
  for (size_t i = 0; i < maps.size(); ++i) {
    if (maps[i].empty()) continue;
    const std::string path = Resolve(dir, maps[i]);
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      err(absl::StrCat("$.maps[", i, "]"), absl::StrCat("no such file: ", path));
    } else {
      map_ok[i] = true;
    }
  }
  canonical.resize(brdfs.size());
  for (size_t i = 0; i < brdfs.size(); ++i) {
    if (brdfs[i].empty()) continue;
    absl::StatusOr<std::unique_ptr<Brdf>> b = ParseBrdfSpec(brdfs[i]);
    if (!b.ok()) {
      err(absl::StrCat("$.brdfs[", i, "]"), std::string(b.status().message()));
    } else {
      brdf_ok[i] = true;
      canonical[i] = (*b)->spec();
    }
  }
  if (m.contains("options")) {
    const nlohmann::json& o = m.at("options");
    if (!o.is_object()) {
      err("$.options", "must be an object");
    } else {
      for (const auto& [key, v] : o.items()) {
        const std::string path = "$.options." + key;
        if (key == "epsilon") {
          if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() < 1))
            err(path, "must be a number in (0, 1)");
          else
            opt->epsilon = v.get<double>();
        } else if (key == "kind") {
          if (!v.is_string() || (v != "global" && v != "local"))
            err(path, "must be \"global\" or \"local\"");
          else
            opt->kind = v.get<std::string>();
        } else if (key == "size") {
          if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > 4096)
            err(path, "must be an integer >= 0 (0: about 10 F_B)");
          else
            opt->size = v.get<int>();
        } else if (key == "orders") {
          std::vector<std::string> parts;
          int f = -1, p = -1;
          if (v.is_string()) parts = absl::StrSplit(v.get<std::string>(), ',');
          if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &f) ||
              !absl::SimpleAtoi(parts[1], &p) || f < 0 || p < 0)
            err(path, "must be a string \"F,P\" with integers F, P >= 0");
          else
            opt->orders = absl::StrCat(f, ",", p);
        } else if (key == "half" || key == "report" || key == "preview") {
          if (!v.is_boolean()) {
            err(path, "must be true or false");
          } else {
            (key == "half"     ? opt->half
             : key == "report" ? opt->report
                               : opt->preview) = v.get<bool>();
          }
        } else if (key == "rotate") {
          bool good = v.is_array() && v.size() == 3;
          if (good) {
            for (const auto& x : v) good = good && x.is_number() && std::isfinite(x.get<double>());
          }
          if (!good)
            err(path, "must be [yaw, pitch, roll] in degrees (three finite numbers)");
          else
            for (const auto& x : v) opt->rotate.push_back(x.get<double>());
        } else {
          err(path,
              "unknown option (expected epsilon, kind, size, orders, half, rotate, report, "
              "preview)");
        }
      }
    }
  }
  std::string pattern;
  if (!m.contains("output")) {
    err("$.output", "missing (a naming pattern such as \"out/{map}_{brdf}.shrm.exr\")");
  } else if (!m.at("output").is_string() || m.at("output").get<std::string>().empty()) {
    err("$.output", "must be a non-empty string");
  } else {
    pattern = m.at("output").get<std::string>();
    // Only {map}, {brdf}, {index} are placeholders.
    std::string rest =
        absl::StrReplaceAll(pattern, {{"{map}", ""}, {"{brdf}", ""}, {"{index}", ""}});
    if (rest.find('{') != std::string::npos || rest.find('}') != std::string::npos) {
      err("$.output", "unknown placeholder (only {map}, {brdf}, {index})");
      pattern.clear();
    } else if (pattern.find("{index}") == std::string::npos) {
      if (maps.size() > 1 && pattern.find("{map}") == std::string::npos) {
        err("$.output", "several maps: the pattern needs {map} (or {index})");
        pattern.clear();
      } else if (brdfs.size() > 1 && pattern.find("{brdf}") == std::string::npos) {
        err("$.output", "several BRDFs: the pattern needs {brdf} (or {index})");
        pattern.clear();
      }
    }
  }
  if (!errors->empty() || pattern.empty()) return;
  std::map<std::string, int> seen;
  for (size_t i = 0; i < maps.size(); ++i) {
    for (size_t j = 0; j < brdfs.size(); ++j) {
      Job job;
      job.index = static_cast<int>(jobs->size());
      job.map_entry = maps[i];
      job.map = Resolve(dir, maps[i]);
      job.brdf = brdfs[j];
      job.canonical_brdf = canonical[j];
      std::string stem = fs::path(maps[i]).filename().string();
      stem = stem.substr(0, stem.find('.'));
      const std::string name = absl::StrReplaceAll(pattern, {{"{map}", stem},
                                                             {"{brdf}", SanitizeSpec(brdfs[j])},
                                                             {"{index}", absl::StrCat(job.index)}});
      job.output = Resolve(dir, name);
      if (opt->report) job.report = OutputStem(job.output) + ".json";
      if (opt->preview) job.preview = OutputStem(job.output) + ".png";
      auto [it, inserted] = seen.emplace(job.output, job.index);
      if (!inserted) {
        err("$.output", absl::StrCat("jobs ", it->second, " and ", job.index, " both write ",
                                     job.output, " (maps[", i, "], brdfs[", j, "])"));
      }
      jobs->push_back(std::move(job));
    }
  }
}

// Why an existing output must be recomputed ("" when it matches the job; then *orders is the
// file's "F_B,P_B").
std::string Mismatch(const Job& job, const BatchOptions& opt, const std::string& source_sha256,
                     std::string* orders) {
  std::error_code ec;
  if (!fs::exists(job.output, ec)) return "new";
  if (!job.report.empty() && !fs::exists(job.report, ec)) return "report missing";
  if (!job.preview.empty() && !fs::exists(job.preview, ec)) return "preview missing";
  absl::StatusOr<ShrmFile> file = ReadShrmFile(job.output);
  if (!file.ok()) return absl::StrCat("existing output unreadable (", file.status().message(), ")");
  const std::map<std::string, std::string>& a = file->attributes;
  if (auto it = a.find("shrm:orders"); it != a.end()) *orders = it->second;
  auto get = [&](const char* key) {
    auto it = a.find(key);
    return it == a.end() ? std::string("(none)") : it->second;
  };
  auto differs = [&](const char* key, const std::string& want) -> std::string {
    const std::string have = get(key);
    return have == want ? "" : absl::StrCat(key, " ", have, " != ", want);
  };
  std::string why;
  if (!(why = differs("shrm:brdf", job.canonical_brdf)).empty()) return why;
  if (!(why = differs("shrm:source_sha256", source_sha256)).empty()) return "source changed";
  if (!(why = differs("shrm:epsilon",
                      opt.orders.empty() ? absl::StrCat(opt.epsilon) : "explicit orders"))
           .empty())
    return why;
  if (!opt.orders.empty() && !(why = differs("shrm:orders", opt.orders)).empty()) return why;
  if (!(why = differs("shrm:rotate_ypr_deg",
                      opt.rotate.empty() ? "(none)" : absl::StrJoin(opt.rotate, ",")))
           .empty())
    return why;
  const ShrmKind kind = opt.kind == "local" ? ShrmKind::kLocal : ShrmKind::kGlobal;
  if (file->cube.kind != kind) return absl::StrCat("kind != ", opt.kind);
  if (opt.size > 0 && file->cube.face_size != opt.size)
    return absl::StrCat("size ", file->cube.face_size, " != ", opt.size);
  return "";
}

absl::Status RunBatch(const BatchArgs& args) {
  if (args.jobs < 1) return absl::InvalidArgumentError("--jobs must be >= 1");
  std::ifstream in(args.manifest, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(args.manifest, ": cannot open the manifest"));
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json manifest;
  try {
    manifest = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::parse_error& e) {
    return absl::InvalidArgumentError(absl::StrCat(args.manifest, ": not JSON: ", e.what()));
  }
  BatchOptions opt;
  std::vector<Job> jobs;
  std::vector<std::string> errors;
  ParseManifest(manifest, fs::path(args.manifest).parent_path(), &opt, &jobs, &errors);
  if (!errors.empty()) {
    for (const std::string& e : errors)
      std::fprintf(stderr, "shrm: %s: %s\n", args.manifest.c_str(), e.c_str());
    return absl::InvalidArgumentError(absl::StrCat(args.manifest, ": ", errors.size(),
                                                   " problem(s) in the manifest; no job was run"));
  }
  for (const Job& job : jobs) {
    std::error_code ec;
    for (const std::string& out : {job.output, job.report, job.preview}) {
      const fs::path parent = fs::path(out).parent_path();
      if (!out.empty() && !parent.empty()) fs::create_directories(parent, ec);
    }
  }

  if (!args.server.empty()) {
    // Upload each map once, before the jobs (which then find it by hash); a failure here is
    // left to the jobs to report.
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c = ConnectServer(args.server);
    std::set<std::string> uploaded;
    for (const Job& job : jobs) {
      if (c.ok() && uploaded.insert(job.map).second) (void)(*c)->UploadIfMissing(job.map);
    }
  }

  const int hw = ResolveThreads(0);
  const int workers = std::min<int>(args.jobs, static_cast<int>(jobs.size()));
  const int threads = args.threads > 0 ? args.threads : std::max(1, hw / workers);
  const bool tty = ::isatty(2);
  std::mutex mu;  // guards the outcome fields, the counters, the hash cache and stderr
  std::map<std::string, std::string> hashes;  // map path -> source SHA-256 (or "" on error)
  int done = 0, failed = 0;
  auto show = [&] {
    if (tty)
      std::fprintf(stderr, "\r[shrm batch] %d/%zu done, %d failed", done, jobs.size(), failed);
  };
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t k; (k = next.fetch_add(1)) < jobs.size();) {
      Job& job = jobs[k];
      const auto start = std::chrono::steady_clock::now();
      std::string status, message, orders;
      int retries = 0;
      EnvArgs env;
      env.files = {job.map};
      env.rotate = opt.rotate;
      std::string reason = "forced";
      if (!args.force) {
        std::string hash;
        {
          std::lock_guard<std::mutex> lock(mu);
          auto it = hashes.find(job.map);
          if (it != hashes.end()) hash = it->second;
        }
        if (hash.empty()) {
          absl::StatusOr<std::string> h = EnvSourceHash(env);
          if (h.ok()) {
            hash = *h;
            std::lock_guard<std::mutex> lock(mu);
            hashes[job.map] = hash;
          }
        }
        reason = hash.empty() ? "new" : Mismatch(job, opt, hash, &orders);
      }
      if (reason.empty()) {
        status = "skipped";
        message = "up to date";
      } else {
        PrefilterArgs a;
        a.env = env;
        a.brdf = job.brdf;
        a.epsilon = opt.epsilon;
        a.orders = opt.orders;
        a.kind = opt.kind;
        a.size = opt.size;
        a.output = job.output;
        a.report = job.report;
        a.preview = job.preview;
        a.half = opt.half;
        a.threads = threads;
        a.server = args.server;
        a.quiet = true;
        PrefilterJobOutcome outcome;
        const absl::Status s = RunPrefilterJob(a, &outcome);
        retries = outcome.retries;
        if (s.ok()) {
          status = "ok";
          orders = absl::StrCat(outcome.f_b, ",", outcome.p_b);
          message = reason == "new" ? "" : absl::StrCat("recomputed: ", reason);
        } else {
          status = "failed";
          orders.clear();
          message = std::string(s.message());
        }
      }
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::lock_guard<std::mutex> lock(mu);
      job.status = status;
      job.message = message;
      job.orders = orders;
      job.seconds = seconds;
      job.retries = retries;
      ++done;
      if (status == "failed") ++failed;
      show();
    }
  };
  show();
  std::vector<std::thread> pool;
  for (int i = 0; i < workers; ++i) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();
  if (tty) std::fprintf(stderr, "\n");

  int ok = 0, skipped = 0, retries = 0;
  for (const Job& j : jobs) {
    ok += j.status == "ok";
    skipped += j.status == "skipped";
    retries += j.retries;
  }
  if (args.json) {
    nlohmann::json out;
    out["manifest"] = args.manifest;
    out["ok"] = ok;
    out["skipped"] = skipped;
    out["failed"] = failed;
    out["retries"] = retries;
    out["jobs"] = nlohmann::json::array();
    for (const Job& j : jobs) {
      out["jobs"].push_back({{"index", j.index},
                             {"map", j.map},
                             {"brdf", j.brdf},
                             {"output", j.output},
                             {"status", j.status},
                             {"orders", j.orders},
                             {"seconds", j.seconds},
                             {"retries", j.retries},
                             {"message", j.message}});
    }
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    size_t width = 3;
    for (const Job& j : jobs) width = std::max(width, j.output.size());
    std::printf("%-3s  %-*s  %-7s  %-7s  %8s  %7s  %s\n", "#", static_cast<int>(width), "job",
                "status", "orders", "seconds", "retries", "message");
    for (const Job& j : jobs) {
      std::printf("%-3d  %-*s  %-7s  %-7s  %8.2f  %7d  %s\n", j.index, static_cast<int>(width),
                  j.output.c_str(), j.status.c_str(), j.orders.empty() ? "-" : j.orders.c_str(),
                  j.seconds, j.retries, j.message.c_str());
    }
    std::printf("%zu jobs: %d ok, %d skipped, %d failed, %d retries\n", jobs.size(), ok, skipped,
                failed, retries);
  }
  std::fflush(stdout);
  if (failed > 0)
    return absl::InternalError(absl::StrCat(failed, " of ", jobs.size(), " jobs failed"));
  return absl::OkStatus();
}

}  // namespace

void RegisterBatch(CLI::App& app, absl::Status* status) {
  auto args = std::make_shared<BatchArgs>();
  CLI::App* sub =
      app.add_subcommand("batch", "prefilter every map of a manifest with every BRDF (resumable)");
  sub->add_option("manifest", args->manifest, "the manifest (JSON, docs/cli.md)")->required();
  sub->add_option("--jobs", args->jobs, "jobs run at once")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--threads", args->threads, "threads per job (0: cores / jobs)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--force", args->force, "recompute every job, even up-to-date outputs");
  sub->add_flag("--json", args->json, "print the summary as JSON on stdout");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunBatch(*args); });
}

}  // namespace shrm::cli
