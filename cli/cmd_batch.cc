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
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "cli/batch_manifest.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "cli/ibl_job.h"
#include "cli/prefilter_job.h"
#include "core/brdf/brdf.h"
#include "core/io/atomic_file.h"
#include "core/shrm/shrm_file.h"
#include "jobs/cli_validators.h"
#include "jobs/ibl_job.h"
#include "jobs/option_text.h"
#include "jobs/report_html.h"

namespace shrm::cli {

namespace fs = std::filesystem;

namespace {

struct BatchArgs {
  std::string manifest;
  int jobs = 1;
  int threads = 0;
  std::string server;
  bool force = false;
  bool json = false;
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

// What a resumed batch knows of an output it skips: its orders, the measured error it records
// and, when it missed its tolerance when it was written, what it missed (reported again, not
// recomputed: docs/cli.md "Resume").
struct ExistingOutput {
  std::string orders;  // "F_B,P_B" (prefilter)
  MeasuredError measured;
  std::string miss;
};

// Why an existing output must be recomputed ("" when it matches the job; then *existing holds
// what the file records).
std::string Mismatch(const BatchJob& job, const std::string& source_sha256,
                     ExistingOutput* existing) {
  std::error_code ec;
  if (!fs::exists(job.output, ec)) return "new";
  if (!job.report.empty() && !fs::exists(job.report, ec)) return "report missing";
  if (!job.preview.empty() && !fs::exists(job.preview, ec)) return "preview missing";
  if (!job.ktx2.empty() && !fs::exists(job.ktx2, ec)) return "KTX2 missing";
  if (!job.report_html.empty() && !fs::exists(job.report_html, ec)) return "visual report missing";
  absl::StatusOr<ShrmFile> file = ReadShrmFile(job.output);
  if (!file.ok()) return absl::StrCat("existing output unreadable (", file.status().message(), ")");
  if (auto it = file->attributes.find("shrm:orders"); it != file->attributes.end()) {
    existing->orders = it->second;
  }
  if (auto m = jobs::FileRecordedError(file->attributes, "shrm:measured_error");
      m && m->pairs > 0) {
    existing->measured.rms = m->error.front.rms;
    existing->measured.max = m->error.front.max;
  }
  existing->miss = jobs::RecordedToleranceMiss(*file);
  return jobs::WhyFileDiffers(job.job, job.canonical_brdf, source_sha256, *file);
}

// Why an existing IBL set must be recomputed ("" when its ibl.json records the job: the map's
// SHA-256 and the same options, and every file it lists exists; then *existing holds what
// ibl.json records).
std::string IblMismatch(const BatchJob& job, const std::string& source_sha256,
                        ExistingOutput* existing) {
  std::error_code ec;
  const std::string sidecar = job.output + "/ibl.json";
  if (!fs::exists(sidecar, ec)) return "new";
  std::ifstream in(sidecar, std::ios::binary);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return "existing ibl.json unreadable";
  if (j.value("source_sha256", "") != source_sha256) return "the map changed";
  {
    // A set without "rules" was chosen by revision 1 of them.
    const auto rules = j.find("rules");
    const std::string have = rules == j.end() ? "1" : rules->dump();
    if (have != absl::StrCat(jobs::kIblRulesRevision))
      return absl::StrCat("chosen by older rules (rules ", have, " != ", jobs::kIblRulesRevision,
                          ")");
  }
  if (!j.contains("options") || j["options"] != jobs::IblOptionsJson(job.ibl_job)) {
    return "other options";
  }
  if (!j.contains("files") || !j["files"].is_array()) return "existing ibl.json lists no files";
  for (const nlohmann::json& f : j["files"]) {
    if (!f.is_object() || !fs::exists(job.output + "/" + f.value("name", ""), ec)) {
      return "a file is missing";
    }
  }
  existing->measured = IblMeasuredError(j);
  if (const auto met = j.find("met"); met != j.end() && met->is_boolean() && !met->get<bool>()) {
    existing->miss = absl::StrFormat(
        "a level missed the tolerance when the set was written (worst measured RMS %.3g, "
        "largest %.3g; ibl.json)",
        existing->measured.rms, existing->measured.max);
  }
  return "";
}

// "rotate": [yaw, pitch, roll] degrees (false when malformed).
bool ParseRotate(const nlohmann::json& v, std::optional<std::array<double, 3>>* out) {
  bool good = v.is_array() && v.size() == 3;
  if (good) {
    for (const auto& x : v) good = good && x.is_number() && std::isfinite(x.get<double>());
  }
  if (good)
    *out = std::array<double, 3>{v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
  return good;
}

constexpr char kRotateError[] = "must be [yaw, pitch, roll] in degrees (three finite numbers)";

// "options" of an IBL manifest, by the names of jobs::IblJobOptions(); types here, ranges by the
// job's validation (with the option named).
void ParseIblOptions(const nlohmann::json& o, jobs::IblJob* job,
                     const std::function<void(const std::string&, const std::string&)>& err) {
  bool preset_given = false, typed = true;
  for (const auto& item : o.items()) {
    // Named references, not a structured binding: clang 14 cannot capture one in a lambda.
    const std::string& key = item.key();
    const nlohmann::json& v = item.value();
    const std::string path = "$.options." + key;
    auto fail = [&](const std::string& what) {
      err(path, what);
      typed = false;
    };
    auto integer = [&](int* out) {
      if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > (1 << 20))
        fail("must be a non-negative integer");
      else
        *out = v.get<int>();
    };
    auto text = [&](const auto& parse, auto* out) {
      auto parsed = v.is_string() ? parse(v.get<std::string>())
                                  : decltype(parse(""))(absl::InvalidArgumentError("not a string"));
      if (!parsed.ok())
        fail(absl::StrCat("must be a string: ", parsed.status().message()));
      else
        *out = *parsed;
    };
    if (key == "preset") {
      text([](const std::string& t) { return ibl::ParseRoughnessPreset(t); }, &job->preset);
      preset_given = true;
    } else if (key == "roughness") {
      bool good = v.is_array() && !v.empty();
      for (const auto& x : v) good = good && x.is_number();
      if (!good)
        fail("must be a non-empty array of numbers (perceptual roughness per level)");
      else
        job->roughness = v.get<std::vector<double>>();
    } else if (key == "size") {
      integer(&job->face_size);
    } else if (key == "levels") {
      integer(&job->levels);
    } else if (key == "irradiance_size") {
      integer(&job->irradiance_size);
    } else if (key == "dfg_size") {
      integer(&job->dfg_size);
    } else if (key == "verify") {
      integer(&job->verify);
    } else if (key == "sheen") {
      if (!v.is_boolean())
        fail("must be true or false");
      else
        job->sheen = v.get<bool>();
    } else if (key == "format") {
      text([](const std::string& t) { return jobs::ParseIblFormat(t); }, &job->format);
    } else if (key == "sh_window") {
      text([](const std::string& t) { return jobs::ParseIblShWindow(t); }, &job->sh_window);
    } else if (key == "dfg") {
      if (!v.is_string())
        fail("must be a string");
      else
        job->dfg = v.get<std::string>();
    } else if (key == "tolerance") {
      if (!v.is_number())
        fail("must be a number in (0, 1)");
      else
        job->tolerance = v.get<double>();
    } else if (key == "preview") {
      if (!v.is_boolean())
        fail("must be true or false");
      else
        job->preview = v.get<bool>();
    } else if (key == "containers") {
      text([](const std::string& t) { return jobs::ParseIblContainers(t); }, &job->containers);
    } else if (key == "rotate") {
      if (!ParseRotate(v, &job->env.rotate_ypr_deg)) fail(kRotateError);
    } else {
      fail(
          "unknown option (expected preset, roughness, size, levels, sheen, format, "
          "irradiance_size, dfg_size, tolerance, verify, sh_window, dfg, containers, preview, "
          "rotate)");
    }
  }
  if (!job->roughness.empty() && !preset_given) job->preset = ibl::RoughnessPreset::kExplicit;
  if (!typed) return;
  jobs::IblJob probe = *job;
  probe.env.files = {"map"};
  const absl::Status s = jobs::ValidateIblJobNamingOptions(
      probe, [](std::string_view option) { return "$.options." + std::string(option); });
  if (!s.ok()) {
    const std::string msg(s.message());
    const size_t colon = msg.find(": ");
    err(msg.substr(0, colon), msg.substr(colon + 2));
  }
}

}  // namespace

absl::StatusOr<nlohmann::json> ParseManifestText(std::string_view text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for 1e400
    return absl::InvalidArgumentError(absl::StrCat("not JSON: ", e.what()));
  }
}

void ParseManifest(const nlohmann::json& m, const fs::path& dir, BatchOptions* opt,
                   std::vector<BatchJob>* jobs, std::vector<std::string>* errors) {
  auto err = [&](const std::string& path, const std::string& what) {
    errors->push_back(absl::StrCat(path, ": ", what));
  };
  if (!m.is_object()) {
    err("$", "the manifest must be a JSON object");
    return;
  }
  // "kind": "prefilter" (the default: maps x BRDFs) or "ibl" (one IBL set per map).
  if (m.contains("kind") && m["kind"] != "prefilter" && m["kind"] != "ibl") {
    err("$.kind", "must be \"prefilter\" or \"ibl\"");
  }
  const bool ibl = m.contains("kind") && m["kind"] == "ibl";
  opt->ibl = ibl;
  for (const auto& [key, value] : m.items()) {
    if (ibl && key == "brdfs") {
      err("$.brdfs", "an ibl manifest has no BRDFs (the IBL set is for any PBR material)");
    } else if (key != "maps" && key != "brdfs" && key != "options" && key != "output" &&
               key != "kind") {
      err("$." + key, "unknown key (expected kind, maps, brdfs, options, output)");
    }
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
  if (ibl) {
    brdfs = {""};  // one job per map
  } else {
    string_list("brdfs", &brdfs);
  }
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
    } else if (ibl) {
      ParseIblOptions(o, &opt->ibl_job, err);
    } else {
      std::optional<double> epsilon, tolerance;  // the order rule: at most one of three
      std::optional<jobs::Orders> orders;
      for (const auto& [key, v] : o.items()) {
        const std::string path = "$.options." + key;
        if (key == "epsilon" || key == "tolerance") {
          if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() < 1))
            err(path, "must be a number in (0, 1)");
          else
            (key == "epsilon" ? epsilon : tolerance) = v.get<double>();
        } else if (key == "max_size") {
          if (!v.is_number() || !(v.get<double>() >= 0 && v.get<double>() <= jobs::kMaxSizeMbLimit))
            err(path, absl::StrCat("must be a number of MB in [0, ", jobs::kMaxSizeMbLimit,
                                   "] (0: no budget)"));
          else
            opt->job.max_size_mb = v.get<double>();
        } else if (key == "verify") {
          if (!v.is_number_integer() || v.get<long long>() < 0 ||
              v.get<long long>() > jobs::kMaxVerifyPairs)
            err(path, absl::StrCat("must be an integer in [0, ", jobs::kMaxVerifyPairs, "]"));
          else
            opt->job.verify = v.get<int>();
        } else if (key == "window") {
          absl::StatusOr<RingingWindow> w = v.is_string()
                                                ? ParseRingingWindow(v.get<std::string>())
                                                : absl::InvalidArgumentError("not a string");
          if (!w.ok())
            err(path, "must be \"none\", \"lanczos\" or \"auto\"");
          else
            opt->job.window = *w;
        } else if (key == "view_variable") {
          absl::StatusOr<std::optional<ViewVariable>> w =
              v.is_string() ? jobs::ParseViewChoice(v.get<std::string>())
                            : absl::InvalidArgumentError("not a string");
          if (!w.ok())
            err(path, "must be \"auto\", \"view\" or \"normal\"");
          else
            opt->job.view = *w;
        } else if (key == "kind") {
          if (!v.is_string() || (v != "global" && v != "local"))
            err(path, "must be \"global\" or \"local\"");
          else
            opt->job.kind = *jobs::ParseShrmKind(v.get<std::string>());
        } else if (key == "size") {
          if (!v.is_number_integer() || v.get<long long>() < 0 ||
              v.get<long long>() > jobs::kMaxFaceSize)
            err(path, absl::StrCat("must be an integer in [0, ", jobs::kMaxFaceSize,
                                   "] (0: about 10 F_B)"));
          else
            opt->job.face_size = v.get<int>();
        } else if (key == "orders") {
          absl::StatusOr<jobs::Orders> parsed =
              v.is_string() ? jobs::ParseOrdersText(v.get<std::string>(), "orders")
                            : absl::InvalidArgumentError("not a string");
          if (!parsed.ok())
            err(path, "must be a string \"F,P\" with integers F, P >= 0");
          else
            orders = *parsed;
        } else if (key == "peak_lights") {
          // "auto", "on", "off"; true and false (the bool it was until session 37) are on and off.
          std::optional<PeakLights> mode;
          if (v.is_boolean()) mode = v.get<bool>() ? PeakLights::kOn : PeakLights::kOff;
          if (v.is_string()) mode = ParsePeakLights(v.get<std::string>());
          if (!mode)
            err(path, "must be \"auto\", \"on\" or \"off\" (or true / false)");
          else
            opt->job.peak_lights = *mode;
        } else if (key == "half" || key == "report" || key == "preview" || key == "ktx2" ||
                   key == "report_html") {
          if (!v.is_boolean()) {
            err(path, "must be true or false");
          } else {
            (key == "half"      ? opt->job.half
             : key == "report"  ? opt->report
             : key == "preview" ? opt->preview
             : key == "ktx2"    ? opt->ktx2
                                : opt->report_html) = v.get<bool>();
          }
        } else if (key == "rotate") {
          if (!ParseRotate(v, &opt->job.env.rotate_ypr_deg)) err(path, kRotateError);
        } else {
          err(path,
              "unknown option (expected epsilon, tolerance, window, view_variable, verify, kind, "
              "size, orders, half, peak_lights, max_size, rotate, report, preview, ktx2, "
              "report_html)");
        }
      }
      if (absl::Status rule = jobs::SetOrderRule(&opt->job, epsilon, tolerance, orders,
                                                 "epsilon, tolerance and orders");
          !rule.ok())
        err("$.options", std::string(rule.message()));
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
    } else if (ibl && pattern.find("{brdf}") != std::string::npos) {
      err("$.output", "an ibl manifest has no {brdf} (the pattern names a folder per map)");
      pattern.clear();
    } else if (!ibl && !absl::EndsWithIgnoreCase(pattern, ".exr")) {
      // As `shrm prefilter -o` (CheckOutputExtension).
      err("$.output", "the SHRMs are written as OpenEXR: the pattern must end in .exr");
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
      BatchJob job;
      job.index = static_cast<int>(jobs->size());
      job.map_entry = maps[i];
      job.map = Resolve(dir, maps[i]);
      job.brdf = brdfs[j];
      job.canonical_brdf = canonical[j];
      job.job = opt->job;
      job.job.env.files = {job.map};
      job.job.brdf = brdfs[j];
      job.ibl = ibl;
      job.ibl_job = opt->ibl_job;
      job.ibl_job.env.files = {job.map};
      std::string stem = fs::path(maps[i]).filename().string();
      stem = stem.substr(0, stem.find('.'));
      const std::string name = absl::StrReplaceAll(pattern, {{"{map}", stem},
                                                             {"{brdf}", SanitizeSpec(brdfs[j])},
                                                             {"{index}", absl::StrCat(job.index)}});
      job.output = Resolve(dir, name);
      if (opt->report) job.report = OutputStem(job.output) + ".json";
      if (opt->preview) job.preview = OutputStem(job.output) + ".png";
      if (opt->ktx2) job.ktx2 = OutputStem(job.output) + ".shrm.ktx2";
      if (opt->report_html) job.report_html = OutputStem(job.output) + ".report.html";
      auto [it, inserted] = seen.emplace(job.output, job.index);
      if (!inserted) {
        err("$.output", absl::StrCat("jobs ", it->second, " and ", job.index, " both write ",
                                     job.output, " (maps[", i, "], brdfs[", j, "])"));
      }
      jobs->push_back(std::move(job));
    }
  }
}

namespace {

// <manifest without .json>.html: the index page of a batch's visual reports.
std::string ReportIndexPath(const std::string& manifest) {
  std::string stem = manifest;
  if (absl::EndsWith(stem, ".json")) stem.resize(stem.size() - 5);
  return stem + ".html";
}

// The index page: every job with a link to its report (relative to the page) and a thumbnail of
// its spheres (a skipped job's from its existing report).
absl::Status WriteReportIndex(const std::string& index, const std::string& manifest,
                              const std::vector<BatchJob>& jobs) {
  const fs::path dir = fs::absolute(fs::path(index)).parent_path();
  std::vector<jobs::ReportIndexEntry> entries;
  for (const BatchJob& j : jobs) {
    jobs::ReportIndexEntry e;
    e.name = fs::path(j.output).filename().string();
    std::error_code ec;
    if (!j.report_html.empty() && fs::exists(j.report_html, ec)) {
      e.report_href = fs::absolute(j.report_html).lexically_relative(dir).generic_string();
      e.thumbnail_png_base64 = j.thumbnail_png_base64;
      if (e.thumbnail_png_base64.empty()) {
        std::ifstream page(j.report_html, std::ios::binary);
        std::stringstream text;
        text << page.rdbuf();
        e.thumbnail_png_base64 = jobs::ReportThumbnailFromPage(text.str());
      }
    }
    e.status = j.status == "failed" || j.status == "missed"
                   ? absl::StrCat(j.status, ": ", j.message)
                   : j.status;
    e.summary = absl::StrCat(
        j.brdf, j.orders.empty() ? "" : absl::StrCat(", (F_B, P_B) = (", j.orders, ")"),
        j.measured_rms < 0 ? ""
                           : absl::StrFormat(", measured RMS %.3g%%, largest %.3g%%",
                                             100 * j.measured_rms, 100 * j.measured_max));
    entries.push_back(std::move(e));
  }
  return WriteFileAtomically(
      index, jobs::RenderReportIndexHtml(absl::StrCat("shrm batch: ", manifest), entries));
}

absl::Status RunBatch(const BatchArgs& args) {
#if !SHRM_CLI_HAS_CLIENT
  if (!args.server.empty()) return RunWithClient();  // before anything is read or written
#endif
  if (args.jobs < 1) return absl::InvalidArgumentError("--jobs must be >= 1");
  if (std::error_code folder_ec; fs::is_directory(args.manifest, folder_ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(args.manifest, ": is a folder, not a manifest (a JSON file)"));
  }
  std::ifstream in(args.manifest, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(args.manifest, ": cannot open the manifest"));
  std::stringstream text;
  text << in.rdbuf();
  absl::StatusOr<nlohmann::json> parsed = ParseManifestText(text.str());
  if (!parsed.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(args.manifest, ": ", parsed.status().message()));
  }
  const nlohmann::json& manifest = *parsed;
  BatchOptions opt;
  std::vector<BatchJob> jobs;
  std::vector<std::string> errors;
  ParseManifest(manifest, fs::path(args.manifest).parent_path(), &opt, &jobs, &errors);
  if (!errors.empty()) {
    for (const std::string& e : errors)
      std::fprintf(stderr, "shrm: %s: %s\n", args.manifest.c_str(), e.c_str());
    return absl::InvalidArgumentError(absl::StrCat(args.manifest, ": ", errors.size(),
                                                   " problem(s) in the manifest; no job was run"));
  }
  // The index page of the visual reports, next to the manifest: checked before any job runs.
  const std::string index = opt.report_html ? ReportIndexPath(args.manifest) : "";
  if (!index.empty()) {
    absl::Status s = CheckOutputPath(index, "the report index");
    if (!s.ok()) return s;
  }

  for (const BatchJob& job : jobs) {
    std::error_code ec;
    for (const std::string& out :
         {job.output, job.report, job.preview, job.ktx2, job.report_html}) {
      const fs::path parent = fs::path(out).parent_path();
      if (!out.empty() && !parent.empty()) fs::create_directories(parent, ec);
    }
  }

#if SHRM_CLI_HAS_CLIENT
  if (!args.server.empty()) {
    // Upload each map once, before the jobs (which then find it by hash); a failure here is
    // left to the jobs to report.
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c = ConnectServer(args.server);
    std::set<std::string> uploaded;
    for (const BatchJob& job : jobs) {
      if (c.ok() && uploaded.insert(job.map).second) (void)(*c)->UploadIfMissing(job.map);
    }
  }
#endif  // SHRM_CLI_HAS_CLIENT

  const int hw = ResolveThreads(0);
  const int workers = std::min<int>(args.jobs, static_cast<int>(jobs.size()));
  const int threads = args.threads > 0 ? args.threads : std::max(1, hw / workers);
  const bool tty = ::isatty(2);
  std::mutex mu;  // guards the outcome fields, the counters, the hash cache and stderr
  std::map<std::string, std::string> hashes;  // map path -> source SHA-256 (or "" on error)
  int done = 0, failed = 0, missed = 0;
  auto show = [&] {
    if (tty)
      std::fprintf(stderr, "\r[shrm batch] %d/%zu done, %d missed, %d failed", done, jobs.size(),
                   missed, failed);
  };
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t k; (k = next.fetch_add(1)) < jobs.size();) {
      BatchJob& job = jobs[k];
      const auto start = std::chrono::steady_clock::now();
      std::string status, message, orders;
      int retries = 0;
      bool written = false;
      MeasuredError measured;
      std::string thumbnail;
      std::string reason = "forced";
      if (!args.force) {
        std::string hash;
        {
          std::lock_guard<std::mutex> lock(mu);
          auto it = hashes.find(job.map);
          if (it != hashes.end()) hash = it->second;
        }
        if (hash.empty()) {
          absl::StatusOr<jobs::SourceIdentity> h =
              jobs::LocalSourceIdentity(job.ibl ? job.ibl_job.env : job.job.env);
          if (h.ok()) {
            hash = h->sha256;
            std::lock_guard<std::mutex> lock(mu);
            hashes[job.map] = hash;
          }
        }
        ExistingOutput existing;
        reason = hash.empty() ? "new"
                 : job.ibl    ? IblMismatch(job, hash, &existing)
                              : Mismatch(job, hash, &existing);
        if (reason.empty()) {
          orders = existing.orders;
          measured = existing.measured;
          // A file that missed its tolerance is complete and up to date, so it is not
          // recomputed; it is reported as missed again, as when it was written.
          status = existing.miss.empty() ? "skipped" : "missed";
          message = existing.miss.empty()
                        ? "up to date"
                        : absl::StrCat("up to date, not recomputed: ", existing.miss);
        }
      }
      if (!reason.empty()) {
        absl::Status s;
        // What both kinds of run take from the batch.
        auto batch_run = [&](auto* run) {
          run->output = job.output;
          run->threads = threads;
          run->server = args.server;
          run->quiet = true;
        };
        if (job.ibl) {
          IblCommandRun run;
          batch_run(&run);
          IblJobOutcome outcome;
          s = RunIblJob(job.ibl_job, run, &outcome);
          retries = outcome.retries;
          measured = outcome.measured;
          written = outcome.written;
        } else {
          PrefilterRun run;
          batch_run(&run);
          run.report = job.report;
          run.preview = job.preview;
          run.ktx2 = job.ktx2;
          run.report_html = job.report_html;
          PrefilterJobOutcome outcome;
          s = RunPrefilterJob(job.job, run, &outcome);
          retries = outcome.retries;
          measured = outcome.measured;
          thumbnail = outcome.thumbnail_png_base64;
          orders = absl::StrCat(outcome.f_b, ",", outcome.p_b);
          written = outcome.written;
        }
        if (s.ok()) {
          status = "ok";
          message = reason == "new" ? "" : absl::StrCat("recomputed: ", reason);
        } else if (written) {  // the outputs are there: the tolerance was missed
          status = "missed";
          message = std::string(s.message());
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
      job.measured_rms = measured.rms;
      job.measured_max = measured.max;
      job.thumbnail_png_base64 = std::move(thumbnail);
      ++done;
      failed += status == "failed";
      missed += status == "missed";
      show();
    }
  };
  show();
  std::vector<std::thread> pool;
  for (int i = 0; i < workers; ++i) pool.emplace_back(work);
  for (std::thread& t : pool) t.join();
  if (tty) std::fprintf(stderr, "\n");

  int ok = 0, skipped = 0, retries = 0;
  for (const BatchJob& j : jobs) {
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
    out["missed"] = missed;
    out["retries"] = retries;
    out["jobs"] = nlohmann::json::array();
    for (const BatchJob& j : jobs) {
      out["jobs"].push_back(
          {{"index", j.index},
           {"kind", j.ibl ? "ibl" : "prefilter"},
           {"map", j.map},
           {"brdf", j.brdf},
           {"output", j.output},
           {"status", j.status},
           {"orders", j.orders},
           {"seconds", j.seconds},
           {"retries", j.retries},
           {"measured", j.measured_rms < 0
                            ? nlohmann::json(nullptr)
                            : nlohmann::json{{"rms", j.measured_rms}, {"max", j.measured_max}}},
           {"message", j.message}});
    }
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    size_t width = 3;
    for (const BatchJob& j : jobs) width = std::max(width, j.output.size());
    // The measured error: relative RMS / largest relative error of the job's own check.
    std::printf("%-3s  %-*s  %-7s  %-7s  %-17s  %8s  %7s  %s\n", "#", static_cast<int>(width),
                "job", "status", "orders", "measured rms/max", "seconds", "retries", "message");
    for (const BatchJob& j : jobs) {
      const std::string measured =
          j.measured_rms < 0 ? "-" : absl::StrFormat("%.2g/%.2g", j.measured_rms, j.measured_max);
      std::printf("%-3d  %-*s  %-7s  %-7s  %-17s  %8.2f  %7d  %s\n", j.index,
                  static_cast<int>(width), j.output.c_str(), j.status.c_str(),
                  j.orders.empty() ? "-" : j.orders.c_str(), measured.c_str(), j.seconds, j.retries,
                  j.message.c_str());
    }
    std::printf("%zu jobs: %d ok, %d skipped, %d missed, %d failed, %d retries\n", jobs.size(), ok,
                skipped, missed, failed, retries);
  }
  std::fflush(stdout);
  if (!index.empty()) {
    absl::Status s = WriteReportIndex(index, args.manifest, jobs);
    if (!s.ok()) return s;
  }
  if (failed + missed > 0) {
    return absl::InternalError(
        absl::StrCat(failed, " of ", jobs.size(), " jobs failed, ", missed,
                     " missed their tolerance (their outputs written: see the messages)"));
  }
  return absl::OkStatus();
}

}  // namespace

void DefineBatch(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<BatchArgs>();
  sub->add_option("manifest", args->manifest, "the manifest (JSON, docs/cli.md)")->required();
  sub->add_option("--jobs", args->jobs, "jobs run at once")
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("--threads", args->threads, "threads per job (0: cores / jobs)")
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_flag("--force", args->force, "recompute every job, even up-to-date outputs");
  sub->add_flag("--json", args->json, "print the summary as JSON on stdout");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunBatch(*args); });
}

}  // namespace shrm::cli
