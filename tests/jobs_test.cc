// The job layer against its specification: the SHRM file's attributes (docs/formats.md), the
// batch's resume check, validation of every option with the message naming it, and the option
// syntax shared by the command-line front ends.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>

#include "core/envmap/envmap.h"
#include "core/io/sha256.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "jobs/analyze_job.h"
#include "jobs/environment.h"
#include "jobs/option_text.h"
#include "jobs/point_jobs.h"
#include "jobs/prefilter_job.h"
#include "shrm/version.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

using jobs::PrefilterJob;

ShrmAnalysis Analysis() {
  ShrmAnalysis an;
  an.f_b = 11;
  an.p_b = 2;
  an.f_brdf = 12;
  an.p_brdf = 3;
  an.eps_light = 0.25;
  an.eps_brdf = 0.0125;
  an.eps_bound = 0.5;
  return an;
}

PrefilterResult Result(int face_size = 0) {
  PrefilterResult r;
  r.analysis = Analysis();
  r.cube.face_size = face_size;
  return r;
}

jobs::PrefilterProvenance Provenance() {
  return {"phong:s=32", {"a.exr", std::string(64, 'a')}, EnvLayout::kLatLong};
}

TEST(PrefilterJob, FileAttributesAreTheDocumentedHeader) {
  PrefilterJob job;
  job.env.files = {"a.exr"};
  job.brdf = "phong:s=32";
  jobs::UseEpsilonRule(&job, 0.03);
  const std::map<std::string, std::string> want = {{"shrm:brdf", "phong:s=32"},
                                                   {"shrm:epsilon", "0.03"},
                                                   {"shrm:orders", "11,2"},
                                                   {"shrm:brdf_orders", "12,3"},
                                                   {"shrm:eps_light", "0.25"},
                                                   {"shrm:eps_brdf", "0.0125"},
                                                   {"shrm:eps_bound", "0.5"},
                                                   {"shrm:window", "none"},
                                                   {"shrm:source", "a.exr"},
                                                   {"shrm:source_sha256", std::string(64, 'a')},
                                                   {"shrm:working_space", "lin_rec709"},
                                                   {"shrm:layout", "latlong"},
                                                   {"shrm:peak_lights", "auto"},
                                                   {"shrm:version", kVersion}};
  EXPECT_EQ(jobs::PrefilterFileAttributes(job, Provenance(), Result()), want);
  // Explicit orders and a rotation.
  jobs::UseExplicitOrders(&job, jobs::Orders{8, 1});
  job.env.rotate_ypr_deg = std::array<double, 3>{30, 10.5, -5};
  const auto attrs = jobs::PrefilterFileAttributes(job, Provenance(), Result());
  EXPECT_EQ(attrs.at("shrm:epsilon"), "explicit orders");
  EXPECT_EQ(attrs.at("shrm:rotate_ypr_deg"), "30,10.5,-5");
}

TEST(PrefilterJob, ReportCarriesTheJobAndItsProvenance) {
  PrefilterJob job;
  job.kind = ShrmKind::kLocal;
  const nlohmann::json r = jobs::PrefilterReportJson(job, Provenance(), Result(64));
  EXPECT_EQ(r["kind"], "local");
  EXPECT_EQ(r["face_size"], 64);
  EXPECT_EQ(r["brdf"], "phong:s=32");
  EXPECT_EQ(r["layout"], "latlong");
  EXPECT_EQ(r["source_sha256"], std::string(64, 'a'));
  EXPECT_EQ(r["shrm_version"], kVersion);
  EXPECT_EQ(r["F_B"], 11);
  EXPECT_EQ(r["P_B"], 2);
}

// A Phong s = 32 job of the tolerance rule at 0.01, and a result of it with the reference orders
// (32, 8) and a truncation estimate of 0.003 RMS, 0.02 largest in front, its estimate met.
PrefilterJob ToleranceJob() {
  PrefilterJob job;
  job.env.files = {"a.exr"};
  job.brdf = "phong:s=32";
  job.tolerance = 0.01;
  return job;
}
PrefilterResult ToleranceResult() {
  PrefilterResult r = Result(48);
  r.tolerance_rule = true;
  r.choice.f_ref = 32;
  r.choice.p_ref = 8;
  r.choice.truncation.front = {10, 0.003, 0.02};
  r.choice.met = true;
  return r;
}

TEST(PrefilterJob, ToleranceRuleRecordsItsEstimateAndSaysWhenItIsMissed) {
  const PrefilterJob job = ToleranceJob();
  PrefilterResult r = ToleranceResult();
  r.choice.f = 11;
  r.choice.p = 2;
  r.choice.face_size = 48;
  r.choice.interpolation.front = {10, 0.004, 0.01};
  r.choice.truncation.grazing = {4, 0.05, 0.25};
  const auto attrs = jobs::PrefilterFileAttributes(job, Provenance(), r);
  EXPECT_EQ(attrs.at("shrm:epsilon"), "per-direction tolerance");
  EXPECT_EQ(attrs.at("shrm:tolerance"), "0.01");
  // RMS in quadrature (0.003, 0.004 -> 0.005), largest summed.
  EXPECT_EQ(attrs.at("shrm:estimated_error"), "0.005,0.03,0.05,0.25");
  const nlohmann::json rep = jobs::PrefilterReportJson(job, Provenance(), r);
  EXPECT_EQ(rep["tolerance"]["met"], true);
  EXPECT_EQ(rep["tolerance"]["targets"]["front_max"], 0.05);
  EXPECT_EQ(rep["tolerance"]["reference_orders"], nlohmann::json::array({32, 8}));
  EXPECT_TRUE(jobs::ToleranceOutcome(job, rep).ok());
  r.choice.met = false;
  const absl::Status missed =
      jobs::ToleranceOutcome(job, jobs::PrefilterReportJson(job, Provenance(), r));
  EXPECT_EQ(missed.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(missed.message().find("not met"), std::string::npos) << missed;
  // The estimate missed, the measurement meets every target: the measurement is the verdict.
  r.verified_pairs = 64;
  r.measured.front = {64, 0.004, 0.03};
  EXPECT_TRUE(jobs::ToleranceOutcome(job, jobs::PrefilterReportJson(job, Provenance(), r)).ok());
  // The estimate met, the measurement not: the measured figure is named.
  r.choice.met = true;
  r.measured.front = {64, 0.004, 0.08};
  EXPECT_EQ(jobs::PrefilterFileAttributes(job, Provenance(), r).at("shrm:measured_error"),
            "0.004,0.08,0,0,64");
  const absl::Status measured =
      jobs::ToleranceOutcome(job, jobs::PrefilterReportJson(job, Provenance(), r));
  EXPECT_EQ(measured.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(measured.message().find("measured front RMS 0.004"), std::string::npos) << measured;
  // In the normal variable the grazing RMS is a target too (docs/shrm.md "The view variable").
  r.measured.front = {64, 0.004, 0.03};
  r.measured.grazing = {8, 0.07, 0.2};
  EXPECT_TRUE(jobs::ToleranceOutcome(job, jobs::PrefilterReportJson(job, Provenance(), r)).ok());
  r.brdf.view = ViewVariable::kNormal;
  const nlohmann::json normal_report = jobs::PrefilterReportJson(job, Provenance(), r);
  EXPECT_EQ(normal_report["view_variable"], "normal");
  EXPECT_EQ(normal_report["tolerance"]["targets"]["grazing_is_target"], true);
  const absl::Status grazing = jobs::ToleranceOutcome(job, normal_report);
  EXPECT_EQ(grazing.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(grazing.message().find("grazing RMS 0.07 (target 0.05)"), std::string::npos) << grazing;
  r.brdf.view = ViewVariable::kView;
  r.measured = {};
  r.measured.front = {64, 0.004, 0.08};
  // A file of another tolerance is recomputed by a resumed batch.
  ShrmFile file;
  file.attributes = attrs;
  file.cube.kind = ShrmKind::kGlobal;
  PrefilterJob other = job;
  other.tolerance = 0.02;
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", std::string(64, 'a'), file), "");
  EXPECT_EQ(jobs::WhyFileDiffers(other, "phong:s=32", std::string(64, 'a'), file),
            "shrm:tolerance 0.01 != 0.02");
}

// A file the tolerance rule chose records the rule's revision; one an older rule chose (no
// shrm:rules: revision 1, before session 45's peak-light split) is recomputed by a resumed batch,
// and the epsilon rule's files do not depend on it.
TEST(PrefilterJob, FilesAnOlderToleranceRuleChoseAreNotUpToDate) {
  static_assert(jobs::kToleranceRulesRevision >= 2, "session 45 changed the rule's choices");
  const PrefilterJob job = ToleranceJob();
  ShrmFile file;
  file.attributes = jobs::PrefilterFileAttributes(job, Provenance(), ToleranceResult());
  file.cube.kind = ShrmKind::kGlobal;
  const std::string sha(64, 'a');
  EXPECT_EQ(file.attributes.at("shrm:rules"), std::to_string(jobs::kToleranceRulesRevision));
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", sha, file), "");
  const std::string now = std::to_string(jobs::kToleranceRulesRevision);
  file.attributes.erase("shrm:rules");
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", sha, file),
            "chosen by an older tolerance rule (shrm:rules 1 != " + now + ")");
  file.attributes["shrm:rules"] = "1";
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", sha, file),
            "chosen by an older tolerance rule (shrm:rules 1 != " + now + ")");
  // The epsilon rule writes no revision and asks for none.
  PrefilterJob eps = job;
  jobs::UseEpsilonRule(&eps, 0.03);
  ShrmFile eps_file;
  eps_file.attributes = jobs::PrefilterFileAttributes(eps, Provenance(), Result());
  eps_file.cube.kind = ShrmKind::kGlobal;
  EXPECT_EQ(eps_file.attributes.count("shrm:rules"), 0u);
  EXPECT_EQ(jobs::WhyFileDiffers(eps, "phong:s=32", sha, eps_file), "");
}

// A file records the job's verdict (shrm:tolerance_met), so that a resumed batch that skips it
// still reports a miss; files written before the verdict was recorded are judged by their
// measured error against the targets of their tolerance.
TEST(PrefilterJob, TheFileRecordsWhetherItsToleranceWasMet) {
  const PrefilterJob job = ToleranceJob();
  PrefilterResult r = ToleranceResult();
  r.verified_pairs = 64;
  r.measured.front = {48, 0.004, 0.03};
  ShrmFile file;
  file.cube.kind = ShrmKind::kGlobal;
  file.attributes = jobs::PrefilterFileAttributes(job, Provenance(), r);
  EXPECT_EQ(file.attributes.at("shrm:tolerance_met"), "true");
  EXPECT_EQ(jobs::RecordedToleranceMiss(file), "");
  // The measurement misses its largest-error target (5 x 0.01): the verdict is false, and the
  // file names the figures.
  r.measured.front = {48, 0.004, 0.08};
  file.attributes = jobs::PrefilterFileAttributes(job, Provenance(), r);
  EXPECT_EQ(file.attributes.at("shrm:tolerance_met"), "false");
  EXPECT_FALSE(jobs::ToleranceOutcome(job, jobs::PrefilterReportJson(job, Provenance(), r)).ok());
  EXPECT_EQ(jobs::RecordedToleranceMiss(file),
            "tolerance 0.01 not met when written: measured front RMS 0.004 (target 0.01), "
            "largest 0.08 (target 0.05) at 64 pairs");
  // Unchecked (--verify 0): the estimate's verdict, its figures named.
  r.verified_pairs = 0;
  r.measured = {};
  r.choice.met = false;
  file.attributes = jobs::PrefilterFileAttributes(job, Provenance(), r);
  EXPECT_EQ(file.attributes.count("shrm:measured_error"), 0u);
  EXPECT_EQ(jobs::RecordedToleranceMiss(file),
            "tolerance 0.01 not met when written: estimated front RMS 0.003 (target 0.01), "
            "largest 0.02 (target 0.05)");
  // A file written before the verdict was recorded: its measurement decides, with the grazing
  // RMS a target in the normal variable (5 x 0.01).
  ShrmFile old;
  old.cube.view = ViewVariable::kNormal;
  old.attributes = {{"shrm:tolerance", "0.01"}, {"shrm:measured_error", "0.004,0.03,0.04,0.2,64"}};
  EXPECT_EQ(jobs::RecordedToleranceMiss(old), "");
  old.attributes["shrm:measured_error"] = "0.004,0.03,0.06,0.2,64";
  EXPECT_EQ(jobs::RecordedToleranceMiss(old),
            "tolerance 0.01 not met when written: measured front RMS 0.004 (target 0.01), "
            "largest 0.03 (target 0.05), grazing RMS 0.06 (target 0.05) at 64 pairs");
  old.cube.view = ViewVariable::kView;  // the grazing RMS is reported, not a target
  EXPECT_EQ(jobs::RecordedToleranceMiss(old), "");
  // Without a tolerance (the epsilon rule, explicit orders) there is nothing to miss.
  old.attributes.erase("shrm:tolerance");
  old.attributes["shrm:measured_error"] = "0.5,0.9,0.6,0.9,64";
  EXPECT_EQ(jobs::RecordedToleranceMiss(old), "");
  // Malformed figures are not read.
  for (const char* bad :
       {"", "0.1,0.2,0.3", "0.1,0.2,0.3,0.4,0", "0.1,x,0.3,0.4,64", "0.1,0.2,0.3,0.4,64,1"}) {
    EXPECT_FALSE(jobs::FileRecordedError({{"shrm:measured_error", bad}}, "shrm:measured_error"))
        << bad;
  }
  const auto parsed = jobs::FileRecordedError({{"shrm:measured_error", "0.1,0.2,0.3,0.4,64"}},
                                              "shrm:measured_error");
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->pairs, 64);
  EXPECT_EQ(parsed->error.grazing.max, 0.4);
}

TEST(PrefilterJob, WhyFileDiffersNamesTheFirstDifference) {
  PrefilterJob job;
  job.env.files = {"a.exr"};
  job.brdf = "phong:s=32";
  jobs::UseEpsilonRule(&job, 0.03);
  ShrmFile file;
  file.attributes = jobs::PrefilterFileAttributes(job, Provenance(), Result());
  file.cube.kind = ShrmKind::kGlobal;
  file.cube.face_size = 40;
  const std::string sha(64, 'a');
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", sha, file), "");
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=8", sha, file), "shrm:brdf phong:s=32 != phong:s=8");
  EXPECT_EQ(jobs::WhyFileDiffers(job, "phong:s=32", std::string(64, 'b'), file), "source changed");
  PrefilterJob eps = job;
  eps.epsilon = 0.05;
  EXPECT_EQ(jobs::WhyFileDiffers(eps, "phong:s=32", sha, file), "shrm:epsilon 0.03 != 0.05");
  // A file of the epsilon rule is not the default job's (the tolerance rule).
  PrefilterJob by_default;
  by_default.env = job.env;
  by_default.brdf = job.brdf;
  EXPECT_EQ(jobs::WhyFileDiffers(by_default, "phong:s=32", sha, file),
            "shrm:epsilon 0.03 != per-direction tolerance");
  PrefilterJob rot = job;
  rot.env.rotate_ypr_deg = std::array<double, 3>{1, 2, 3};
  EXPECT_EQ(jobs::WhyFileDiffers(rot, "phong:s=32", sha, file),
            "shrm:rotate_ypr_deg (none) != 1,2,3");
  PrefilterJob local = job;
  local.kind = ShrmKind::kLocal;
  EXPECT_EQ(jobs::WhyFileDiffers(local, "phong:s=32", sha, file), "kind != local");
  PrefilterJob size = job;
  size.face_size = 32;
  EXPECT_EQ(jobs::WhyFileDiffers(size, "phong:s=32", sha, file), "size 40 != 32");
}

// The defaults (docs/shrm.md "Defaults"): the per-direction tolerance rule at 1% within 256 MB,
// checked at 64 pairs; a front end gives at most one order rule.
TEST(PrefilterJob, DefaultIsTheToleranceRuleCheckedAndOneRuleAtATime) {
  PrefilterJob job;
  EXPECT_EQ(job.tolerance, 0.01);
  EXPECT_EQ(job.max_size_mb, 256);
  EXPECT_EQ(job.verify, 64);
  EXPECT_FALSE(job.orders.has_value());
  EXPECT_STREQ(jobs::OrderRuleName(job), "tolerance");
  EXPECT_EQ(jobs::EpsilonAttribute(job), "per-direction tolerance");
  EXPECT_TRUE(jobs::SetOrderRule(&job, std::nullopt, std::nullopt, std::nullopt, "x").ok());
  EXPECT_EQ(job, PrefilterJob{});  // none given: the default stays
  ASSERT_TRUE(jobs::SetOrderRule(&job, 0.05, std::nullopt, std::nullopt, "x").ok());
  EXPECT_STREQ(jobs::OrderRuleName(job), "epsilon");
  EXPECT_EQ(job.tolerance, 0);
  EXPECT_EQ(jobs::EpsilonAttribute(job), "0.05");
  ASSERT_TRUE(jobs::SetOrderRule(&job, std::nullopt, std::nullopt, jobs::Orders{8, 1}, "x").ok());
  EXPECT_STREQ(jobs::OrderRuleName(job), "explicit");
  EXPECT_EQ(job.tolerance, 0);
  ASSERT_TRUE(jobs::SetOrderRule(&job, std::nullopt, 0.02, std::nullopt, "x").ok());
  EXPECT_STREQ(jobs::OrderRuleName(job), "tolerance");
  EXPECT_FALSE(job.orders.has_value());
  // The view variable: auto resolves to the normal with the tolerance rule, to the paper's view
  // with the epsilon rule and explicit orders; an explicit choice is kept.
  EXPECT_FALSE(PrefilterJob{}.view.has_value());
  EXPECT_EQ(jobs::ResolvedViewVariable(PrefilterJob{}), ViewVariable::kNormal);
  EXPECT_EQ(jobs::CorePrefilterOptions(PrefilterJob{}, 1).view, ViewVariable::kNormal);
  EXPECT_TRUE(jobs::CorePrefilterOptions(PrefilterJob{}, 1).try_other_view);
  PrefilterJob eps;
  jobs::UseEpsilonRule(&eps, 0.03);
  EXPECT_EQ(jobs::ResolvedViewVariable(eps), ViewVariable::kView);
  PrefilterJob orders;
  jobs::UseExplicitOrders(&orders, jobs::Orders{8, 2});
  EXPECT_EQ(jobs::ResolvedViewVariable(orders), ViewVariable::kView);
  orders.view = ViewVariable::kNormal;
  EXPECT_EQ(jobs::CorePrefilterOptions(orders, 1).view, ViewVariable::kNormal);
  EXPECT_FALSE(jobs::CorePrefilterOptions(orders, 1).try_other_view);
  PrefilterJob viewed;
  viewed.view = ViewVariable::kView;
  EXPECT_EQ(jobs::ResolvedViewVariable(viewed), ViewVariable::kView);
  EXPECT_FALSE(jobs::CorePrefilterOptions(viewed, 1).try_other_view);  // asked for: kept
  for (const char* name : {"auto", "view", "normal"})
    EXPECT_STREQ(jobs::ViewChoiceName(*jobs::ParseViewChoice(name)), name);
  EXPECT_EQ(jobs::ParseViewChoice("halfway").status().code(), absl::StatusCode::kInvalidArgument);
  const absl::Status two = jobs::SetOrderRule(&job, 0.05, 0.02, std::nullopt, "--a and --b");
  EXPECT_EQ(two.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(two.message().find("--a and --b exclude each other"), std::string::npos) << two;
}

TEST(PrefilterJob, ValidationNamesTheOption) {
  PrefilterJob ok;
  ok.env.files = {"a.exr"};
  ok.brdf = "lambert";
  EXPECT_TRUE(jobs::ValidatePrefilterJob(ok).ok());
  PrefilterJob unrotated = ok;  // the same orders without a rotation are the map's to resolve
  jobs::UseExplicitOrders(&unrotated, jobs::Orders{kMaxRotationLmax + 1, 0});
  EXPECT_TRUE(jobs::ValidatePrefilterJob(unrotated).ok());
  struct Case {
    void (*change)(PrefilterJob*);
    const char* names;
  };
  const Case cases[] = {
      {[](PrefilterJob* j) {
         j->env.files = {"a", "b"};
       },
       "six cube faces"},
      {[](PrefilterJob* j) { j->brdf.clear(); }, "brdf"},
      {[](PrefilterJob* j) { j->epsilon = 1; }, "epsilon"},
      {[](PrefilterJob* j) { j->epsilon = NAN; }, "epsilon"},
      {[](PrefilterJob* j) {
         jobs::UseExplicitOrders(j, jobs::Orders{-1, 0});
       },
       "orders: F"},
      {[](PrefilterJob* j) {
         jobs::UseExplicitOrders(j, jobs::Orders{8, jobs::kMaxOrderP + 1});
       },
       "orders: F"},
      {[](PrefilterJob* j) { j->face_size = jobs::kMaxFaceSize + 1; }, "size"},
      {[](PrefilterJob* j) { j->tolerance = 1; }, "tolerance"},
      {[](PrefilterJob* j) { j->verify = -1; }, "verify"},
      {[](PrefilterJob* j) { j->tolerance = NAN; }, "tolerance"},
      {[](PrefilterJob* j) {
         j->tolerance = 0.01;
         j->orders = jobs::Orders{8, 1};
       },
       "tolerance and orders"},
      {[](PrefilterJob* j) {
         j->env.rotate_ypr_deg = std::array<double, 3>{0, INFINITY, 0};
       },
       "rotate"},
      // A rotated map's lighting stops at degree 256 (core/sh/rotation.h), even a turntable's
      // yaw-0 frame.
      {[](PrefilterJob* j) {
         jobs::UseExplicitOrders(j, jobs::Orders{kMaxRotationLmax + 1, 0});
         j->env.rotate_ypr_deg = std::array<double, 3>{0, 0, 0};
       },
       "orders: F 257 is above 256, the largest degree a rotated map's lighting supports"},
      {[](PrefilterJob* j) {
         jobs::UseEpsilonRule(j, 0.03);
         j->view = ViewVariable::kNormal;
       },
       "view-variable normal"},
  };
  for (const Case& c : cases) {
    PrefilterJob job = ok;
    c.change(&job);
    const absl::Status s = jobs::ValidatePrefilterJob(job);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << c.names;
    EXPECT_NE(s.message().find(c.names), std::string::npos) << s;
  }
}

TEST(Environment, SourceIdentityOfSixFacesHashesTheirHashes) {
  const std::vector<std::string> six = {"1", "2", "3", "4", "5", "6"};
  EXPECT_EQ(jobs::CombinedSourceSha256(six), Sha256Hex("1,2,3,4,5,6"));
  EXPECT_EQ(jobs::CombinedSourceSha256({"abc"}), "abc");
}

TEST(OptionText, ParsesAndNamesTheOption) {
  absl::StatusOr<Vec3> d = jobs::ParseDirectionText("0,3,4", "--view");
  ASSERT_TRUE(d.ok());
  EXPECT_DOUBLE_EQ(d->y, 0.6);
  EXPECT_DOUBLE_EQ(d->z, 0.8);
  for (const char* bad : {"1,2", "a,b,c", "0,0,0", "1,2,3,4", "nan,0,1"}) {
    absl::StatusOr<Vec3> r = jobs::ParseDirectionText(bad, "--view");
    EXPECT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("--view"), std::string::npos) << r.status();
  }
  // A unit vector is kept bit for bit (what travels over the wire is used as it is).
  const Vec3 unit{0.6, 0.8, 0};
  absl::StatusOr<Vec3> u = jobs::UnitDirection(unit, "index");
  ASSERT_TRUE(u.ok());
  EXPECT_EQ(u->x, unit.x);
  EXPECT_EQ(u->y, unit.y);
  absl::StatusOr<jobs::Orders> o = jobs::ParseOrdersText("12,3", "--orders");
  ASSERT_TRUE(o.ok());
  EXPECT_EQ(*o, (jobs::Orders{12, 3}));
  EXPECT_FALSE(jobs::ParseOrdersText("12", "--orders").ok());
  EXPECT_FALSE(jobs::ParseOrdersText("-1,2", "--orders").ok());
  EXPECT_TRUE(jobs::ParseToleranceText("0.5", "--epsilon").ok());
  EXPECT_FALSE(jobs::ParseToleranceText("1", "--epsilon").ok());
  EXPECT_FALSE(jobs::ParseToleranceText("x", "--epsilon").ok());
}

TEST(AnalyzeJob, DefaultsAndValidation) {
  EXPECT_TRUE(jobs::ValidateAnalyzeEpsilons(jobs::kDefaultAnalyzeEpsilons).ok());
  EXPECT_FALSE(jobs::ValidateAnalyzeEpsilons({0.1, 0}).ok());
  const nlohmann::json j = jobs::BrdfOrdersJson(0.1, 8, 2, 0.05);
  EXPECT_EQ(j["F_B"], 8);
  EXPECT_EQ(j["P_B"], 2);
  EXPECT_TRUE(j["F_L"].is_null());
}

// The irradiance job's check (MeasureIrradianceSh9): zero up to the 16 x 16 lookup for a map of
// degree <= 2 (nothing truncated), and on a real map with a sun the l <= 2 truncation this test
// measures itself at its own normals (a double sum over every pixel, sum L dOmega max(n.w, 0)).
TEST(IrradianceJob, MeasuredErrorIsTheTruncationAgainstThePixelSum) {
  // Bilinear lookup of a degree-2 function on 16 x 16 faces: ~h^2 / 8 x |f''| ~ 1e-3.
  constexpr double kLookupTol = 5e-3;
  // Two sets of 200 normals estimate the same RMS: within this factor of each other.
  constexpr double kSamplingFactor = 1.5;
  constexpr int kNormals = 200;
  const EnvMap smooth = EnvMap::FromLatLong(testing::BandLimitedLatLong(2, 3, 64, 32));
  auto e_smooth = jobs::IrradianceSh9(smooth, Mat3::Identity(), 2);
  ASSERT_TRUE(e_smooth.ok()) << e_smooth.status();
  const ibl::LevelError m0 =
      jobs::MeasureIrradianceSh9(smooth, Mat3::Identity(), *e_smooth, kNormals, 2);
  EXPECT_EQ(m0.count, kNormals);
  EXPECT_LT(m0.rms, kLookupTol);
  EXPECT_EQ(jobs::MeasureIrradianceSh9(smooth, Mat3::Identity(), *e_smooth, 0, 2).count, 0);

  const Image img = testing::LoadBundledMap("courtyard.exr", 256);
  const EnvMap env = EnvMap::FromLatLong(img);
  auto e9 = jobs::IrradianceSh9(env, Mat3::Identity(), 2);
  ASSERT_TRUE(e9.ok()) << e9.status();
  const ibl::LevelError m = jobs::MeasureIrradianceSh9(env, Mat3::Identity(), *e9, kNormals, 2);
  const std::vector<EnvSample> samples = testing::LatLongSamples(img);
  std::mt19937 rng(21);
  std::normal_distribution<double> g;
  std::vector<std::array<double, 3>> got, ref;
  double mean = 0;
  for (int k = 0; k < kNormals; ++k) {
    const Vec3 n = Vec3{g(rng), g(rng), g(rng)}.Normalized();
    std::array<double, 3> sum{0, 0, 0}, sh{0, 0, 0};
    for (const EnvSample& s : samples)
      for (int c = 0; c < 3; ++c) sum[c] += s.rgb[c] * s.solid_angle * std::max(0.0, n.Dot(s.dir));
    const std::vector<double> y = EvalSh(2, ShFrameFromWorld(n));
    for (int i = 0; i < ShCount(2); ++i)
      for (int c = 0; c < 3; ++c) sh[c] += (*e9)[static_cast<size_t>(i) * 3 + c] * y[i];
    got.push_back(sh);
    ref.push_back(sum);
    for (int c = 0; c < 3; ++c) mean += std::abs(sum[c]) / (3.0 * kNormals);
  }
  double sq = 0;
  for (int k = 0; k < kNormals; ++k)
    for (int c = 0; c < 3; ++c) {
      const double e = std::abs(got[k][c] - ref[k][c]) / std::max(std::abs(ref[k][c]), 0.01 * mean);
      sq += e * e;
    }
  const double rms = std::sqrt(sq / (3.0 * kNormals));
  std::printf("courtyard SH9 irradiance: measured RMS %.4f largest %.4f; this test's RMS %.4f\n",
              m.rms, m.max, rms);
  EXPECT_GT(m.rms, 10 * kLookupTol);  // a sun: the truncation is visible
  EXPECT_LT(m.rms, kSamplingFactor * rms);
  EXPECT_GT(m.rms, rms / kSamplingFactor);
}

}  // namespace
}  // namespace shrm
