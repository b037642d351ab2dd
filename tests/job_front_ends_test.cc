// Every front end carries every job option the job layer declares for it (jobs/job_options.h),
// and exposes none it does not declare: the `shrm prefilter` flags, the batch manifest's
// "options" and the wire's PrefilterRequest. Each option's example value must reach the job
// unchanged through each front end that carries it.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "cli/batch_manifest.h"
#include "cli/commands.h"
#include "cli/prefilter_job.h"
#include "jobs/job_options.h"
#include "jobs/prefilter_job.h"
#include "proto/job_codec.h"

namespace shrm {
namespace {

using jobs::JobOption;
using jobs::PrefilterJob;

constexpr char kBrdf[] = "phong:s=8";
const std::string kMap = std::string(SHRM_SOURCE_DIR) + "/data/envmaps/interior.exr";

// Options of `shrm prefilter` that are not job options: outputs, execution, the connection.
const std::set<std::string> kRunFlags = {
    "help",   "output",     "report", "preview",  "threads", "json",           "verbose",
    "server", "token-file", "tls-ca", "tls-cert", "tls-key", "tls-server-name"};
// Manifest "options" keys that are not job options: which outputs a batch writes.
const std::set<std::string> kManifestOutputKeys = {"report", "preview"};
// PrefilterRequest / Environment fields that carry no job option: the blobs and names of the
// inputs (what EncodeEnvironment is given besides the spec) and the outputs asked for.
const std::set<std::string> kWireInputFields = {"sha256", "source_names", "brdf_blob_sha256",
                                                "brdf_display_spec", "outputs"};

PrefilterJob BaseJob() {
  PrefilterJob job;
  job.env.files = {kMap};
  job.brdf = kBrdf;
  return job;
}

PrefilterJob WithExample(const JobOption& o) {
  PrefilterJob job = BaseJob();
  o.apply_example(&job);
  return job;
}

std::string CliFlag(const JobOption& o) {
  return absl::StrCat("--", absl::StrReplaceAll(std::string(o.name), {{"_", "-"}}));
}

TEST(JobOptionsTable, NamesAreUniqueAndExamplesChangeTheJob) {
  std::set<std::string> names;
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    EXPECT_TRUE(names.insert(std::string(o.name)).second) << o.name;
    EXPECT_FALSE(o.help.empty()) << o.name;
    EXPECT_FALSE(WithExample(o) == BaseJob()) << o.name << ": the example sets nothing";
    const bool everywhere = o.front_ends == (jobs::kCommandLine | jobs::kManifest | jobs::kWire);
    EXPECT_EQ(o.why_not_everywhere.empty(), everywhere) << o.name;
    EXPECT_EQ(o.manifest_example.empty(), !(o.front_ends & jobs::kManifest)) << o.name;
  }
}

TEST(JobFrontEnds, CommandLineCarriesEveryDeclaredOption) {
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    if (!(o.front_ends & jobs::kCommandLine)) continue;
    const std::vector<std::string> example = absl::StrSplit(std::string(o.cli_example), ' ');
    ASSERT_EQ(example[0], CliFlag(o)) << "the example must use the option's flag";
    // The base command line, without the flag the example gives.
    std::vector<std::string> args = {"prefilter", "-o", "x.shrm.exr"};
    if (o.name != "env") args.insert(args.end(), {"--env", kMap});
    if (o.name != "brdf") args.insert(args.end(), {"--brdf", kBrdf});
    args.insert(args.end(), example.begin(), example.end());
    absl::StatusOr<PrefilterJob> job = cli::ParsePrefilterCommandLine(args);
    ASSERT_TRUE(job.ok()) << o.name << ": " << job.status();
    PrefilterJob want = WithExample(o);
    EXPECT_TRUE(*job == want) << o.name << ": " << o.cli_example << " did not reach the job";
  }
}

TEST(JobFrontEnds, CommandLineExposesNoUndeclaredJobOption) {
  CLI::App app;
  absl::Status status;
  cli::RegisterPrefilter(app, &status);
  CLI::App* sub = app.get_subcommand("prefilter");
  std::set<std::string> declared;
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    if (o.front_ends & jobs::kCommandLine) declared.insert(CliFlag(o).substr(2));
  }
  std::set<std::string> exposed;
  for (const CLI::Option* opt : sub->get_options()) {
    for (const std::string& name : opt->get_lnames()) {
      exposed.insert(name);
      EXPECT_TRUE(declared.count(name) || kRunFlags.count(name))
          << "--" << name << " is neither a declared job option nor a run option";
    }
  }
  for (const std::string& name : declared) EXPECT_TRUE(exposed.count(name)) << "--" << name;
}

TEST(JobFrontEnds, ManifestCarriesEveryDeclaredOptionAndRefusesTheOthers) {
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    nlohmann::json m = {{"maps", {kMap}}, {"brdfs", {kBrdf}}, {"output", "o.shrm.exr"}};
    const bool carried = o.front_ends & jobs::kManifest;
    m["options"][std::string(o.name)] =
        carried ? nlohmann::json::parse(std::string(o.manifest_example)) : nlohmann::json("x");
    cli::BatchOptions options;
    std::vector<cli::BatchJob> jobs;
    std::vector<std::string> errors;
    cli::ParseManifest(m, "", &options, &jobs, &errors);
    if (!carried) {
      ASSERT_FALSE(errors.empty()) << o.name << " must be refused in a manifest";
      EXPECT_NE(errors[0].find("unknown option"), std::string::npos) << errors[0];
      continue;
    }
    ASSERT_TRUE(errors.empty()) << o.name << ": " << errors[0];
    ASSERT_EQ(jobs.size(), 1u);
    EXPECT_TRUE(jobs[0].job == WithExample(o)) << o.name << ": did not reach the job";
  }
  // And the manifest's own keys are only outputs.
  for (const std::string& key : kManifestOutputKeys) {
    EXPECT_EQ(jobs::FindPrefilterJobOption(key), nullptr) << key;
  }
}

// Fake blob hashes for the job's files.
std::vector<std::string> Hashes(const PrefilterJob& job) {
  std::vector<std::string> h;
  for (size_t i = 0; i < job.env.files.size(); ++i) h.push_back(std::string(64, "0123456789"[i]));
  return h;
}

absl::StatusOr<shrm::v1::PrefilterRequest> Encode(const PrefilterJob& job) {
  shrm::v1::Environment env;
  absl::Status s = wire::EncodeEnvironment(job.env, Hashes(job), &env);
  if (!s.ok()) return s;
  return wire::EncodePrefilterRequest(job, env, wire::WireBrdf{job.brdf, "", ""});
}

TEST(JobFrontEnds, WireCarriesEveryDeclaredOptionAndRefusesTheOthers) {
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    const PrefilterJob job = WithExample(o);
    absl::StatusOr<shrm::v1::PrefilterRequest> req = Encode(job);
    if (!(o.front_ends & jobs::kWire)) {
      EXPECT_EQ(req.status().code(), absl::StatusCode::kInvalidArgument) << o.name;
      continue;
    }
    ASSERT_TRUE(req.ok()) << o.name << ": " << req.status();
    absl::StatusOr<wire::WirePrefilter> back = wire::DecodePrefilterRequest(*req);
    ASSERT_TRUE(back.ok()) << o.name << ": " << back.status();
    EXPECT_TRUE(back->job == job) << o.name << ": lost on the wire";
    EXPECT_EQ(back->sha256, Hashes(job));
  }
}

// Every field of the request is written by some option (its encoding differs from the base
// job's) or is one of the inputs' fields: a field no option reaches is a forgotten option.
TEST(JobFrontEnds, WireHasNoFieldWithoutAnOption) {
  const absl::StatusOr<shrm::v1::PrefilterRequest> base = Encode(BaseJob());
  ASSERT_TRUE(base.ok());
  std::set<std::string> reached;
  for (const JobOption& o : jobs::PrefilterJobOptions()) {
    if (!(o.front_ends & jobs::kWire)) continue;
    absl::StatusOr<shrm::v1::PrefilterRequest> req = Encode(WithExample(o));
    ASSERT_TRUE(req.ok());
    // Marks the fields in which `a` and `b` differ (each compared with the others cleared).
    auto compare = [&](const google::protobuf::Message& a, const google::protobuf::Message& b) {
      const google::protobuf::Descriptor* d = a.GetDescriptor();
      for (int i = 0; i < d->field_count(); ++i) {
        std::unique_ptr<google::protobuf::Message> ca(a.New()), cb(b.New());
        ca->CopyFrom(a);
        cb->CopyFrom(b);
        for (int k = 0; k < d->field_count(); ++k) {
          if (k == i) continue;
          ca->GetReflection()->ClearField(ca.get(), d->field(k));
          cb->GetReflection()->ClearField(cb.get(), d->field(k));
        }
        if (ca->SerializeAsString() != cb->SerializeAsString()) reached.insert(d->field(i)->name());
      }
    };
    compare(*req, *base);
    compare(req->environment(), base->environment());
  }
  for (const google::protobuf::Descriptor* d :
       {shrm::v1::PrefilterRequest::descriptor(), shrm::v1::Environment::descriptor()}) {
    for (int i = 0; i < d->field_count(); ++i) {
      const std::string name = d->field(i)->name();
      if (name == "environment" || kWireInputFields.count(name)) continue;
      EXPECT_TRUE(reached.count(name)) << d->name() << "." << name << " carries no job option";
    }
  }
}

}  // namespace
}  // namespace shrm
