// Every front end carries every job option the job layer declares for it (jobs/job_options.h),
// and exposes none it does not declare: the `shrm prefilter` and `shrm ibl` flags, the batch
// manifest's "options" (of both kinds) and the wire's PrefilterRequest and IblRequest. Each
// option's example value must reach the job unchanged through each front end that carries it.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "cli/batch_manifest.h"
#include "cli/commands.h"
#include "cli/ibl_job.h"
#include "cli/prefilter_job.h"
#include "jobs/ibl_job.h"
#include "jobs/job_options.h"
#include "jobs/prefilter_job.h"
#include "proto/job_codec.h"

namespace shrm {
namespace {

using jobs::IblJob;
using jobs::IblJobOption;
using jobs::JobOption;
using jobs::PrefilterJob;

constexpr char kBrdf[] = "phong:s=8";
const std::string kMap = std::string(SHRM_SOURCE_DIR) + "/data/envmaps/interior.exr";

// Options of `shrm prefilter` that are not job options: outputs, execution, the connection.
const std::set<std::string> kRunFlags = {"help",     "output",  "report",         "report-html",
                                         "preview",  "ktx2",    "threads",        "json",
                                         "verbose",  "server",  "token-file",     "tls-ca",
                                         "tls-cert", "tls-key", "tls-server-name"};
// Manifest "options" keys that are not job options: which outputs a batch writes.
const std::set<std::string> kManifestOutputKeys = {"report", "preview", "ktx2", "report_html"};
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

IblJob IblBaseJob() {
  IblJob job;
  job.env.files = {kMap};
  return job;
}

IblJob WithExample(const IblJobOption& o) {
  IblJob job = IblBaseJob();
  o.apply_example(&job);
  return job;
}

template <typename Option>
std::string CliFlag(const Option& o) {
  return absl::StrCat("--", absl::StrReplaceAll(std::string(o.name), {{"_", "-"}}));
}

// Unique names, help texts, examples that change the job, and a reason for every front end that
// does not carry an option.
template <typename Option, typename Job>
void CheckTable(std::span<const Option> table, const Job& base) {
  std::set<std::string> names;
  for (const Option& o : table) {
    EXPECT_TRUE(names.insert(std::string(o.name)).second) << o.name;
    EXPECT_FALSE(o.help.empty()) << o.name;
    EXPECT_FALSE(WithExample(o) == base) << o.name << ": the example sets nothing";
    const bool everywhere = o.front_ends == (jobs::kCommandLine | jobs::kManifest | jobs::kWire);
    EXPECT_EQ(o.why_not_everywhere.empty(), everywhere) << o.name;
    EXPECT_EQ(o.manifest_example.empty(), !(o.front_ends & jobs::kManifest)) << o.name;
  }
}

TEST(JobOptionsTable, NamesAreUniqueAndExamplesChangeTheJob) {
  CheckTable(jobs::PrefilterJobOptions(), BaseJob());
  CheckTable(jobs::IblJobOptions(), IblBaseJob());
  // The IBL examples are valid jobs (the command line and the wire validate them).
  for (const IblJobOption& o : jobs::IblJobOptions()) {
    EXPECT_TRUE(jobs::ValidateIblJob(WithExample(o)).ok()) << o.name;
  }
}

// Each declared flag's example, added to `base_args` (and --env unless it is the example),
// reaches the job through `parse`.
template <typename Option, typename Parse>
void CheckCommandLine(std::span<const Option> table, std::vector<std::string> base_args,
                      const Parse& parse) {
  for (const Option& o : table) {
    if (!(o.front_ends & jobs::kCommandLine)) continue;
    const std::vector<std::string> example = absl::StrSplit(std::string(o.cli_example), ' ');
    ASSERT_EQ(example[0], CliFlag(o)) << "the example must use the option's flag";
    std::vector<std::string> args = base_args;
    if (o.name != "env") args.insert(args.end(), {"--env", kMap});
    if (o.name == "brdf") args.erase(args.begin() + 3, args.begin() + 5);  // the base's --brdf
    args.insert(args.end(), example.begin(), example.end());
    auto job = parse(args);
    ASSERT_TRUE(job.ok()) << o.name << ": " << job.status();
    EXPECT_TRUE(*job == WithExample(o))
        << o.name << ": " << o.cli_example << " did not reach the job";
  }
}

TEST(JobFrontEnds, CommandLineCarriesEveryDeclaredOption) {
  CheckCommandLine(jobs::PrefilterJobOptions(), {"prefilter", "-o", "x.shrm.exr", "--brdf", kBrdf},
                   cli::ParsePrefilterCommandLine);
  CheckCommandLine(jobs::IblJobOptions(), {"ibl", "-o", "x_ibl"}, cli::ParseIblCommandLine);
}

// The flags of `subcommand` are declared job options or `run_flags`, and every declared one is
// there.
template <typename Option>
void CheckNoUndeclaredFlags(std::span<const Option> table, const char* subcommand,
                            void (*define_command)(CLI::App*, absl::Status*)) {
  CLI::App app;
  absl::Status status;
  CLI::App* sub = app.add_subcommand(subcommand);
  define_command(sub, &status);
  std::set<std::string> declared;
  for (const Option& o : table) {
    if (o.front_ends & jobs::kCommandLine) declared.insert(CliFlag(o).substr(2));
  }
  std::set<std::string> exposed;
  for (const CLI::Option* opt : sub->get_options()) {
    for (const std::string& name : opt->get_lnames()) {
      exposed.insert(name);
      EXPECT_TRUE(declared.count(name) || kRunFlags.count(name))
          << subcommand << " --" << name << " is neither a declared job option nor a run option";
    }
  }
  for (const std::string& name : declared) {
    EXPECT_TRUE(exposed.count(name)) << subcommand << " --" << name;
  }
}

TEST(JobFrontEnds, CommandLineExposesNoUndeclaredJobOption) {
  CheckNoUndeclaredFlags(jobs::PrefilterJobOptions(), "prefilter", cli::DefinePrefilter);
  CheckNoUndeclaredFlags(jobs::IblJobOptions(), "ibl", cli::DefineIbl);
}

// The command table (cli/commands.h): `shrm --help` lists every subcommand, and only the one a
// command line names is defined. Each entry's Define gives its subcommand options and a callback.
TEST(CommandTable, EveryCommandIsListedOnceAndDefinesItsOptions) {
  std::set<std::string> names;
  for (const cli::Command& c : cli::Commands()) {
    EXPECT_TRUE(names.insert(std::string(c.name)).second) << c.name << " listed twice";
    EXPECT_FALSE(c.description.empty()) << c.name;
    CLI::App app;
    absl::Status status;
    CLI::App* sub = app.add_subcommand(std::string(c.name), std::string(c.description));
    const size_t before = sub->get_options().size();  // -h,--help
    c.define(sub, &status);
    EXPECT_GT(sub->get_options().size(), before) << c.name << " defines no option";
  }
  // docs/cli.md's list.
  EXPECT_EQ(names, (std::set<std::string>{"analyze", "prefilter", "eval", "reference", "render",
                                          "explicit", "irradiance", "ibl", "info", "batch", "live",
                                          "sky", "brdf-table"}));
}

// CLI11's rule: the first argument that is not an option selects the subcommand (the program's
// own options, --help and --version, take no value).
TEST(CommandTable, TheFirstArgumentThatIsNotAnOptionChoosesTheCommand) {
  auto chosen = [](std::vector<const char*> argv) -> std::string {
    argv.insert(argv.begin(), "shrm");
    const cli::Command* c = cli::ChosenCommand(static_cast<int>(argv.size()), argv.data());
    return c != nullptr ? std::string(c->name) : "(none)";
  };
  EXPECT_EQ(chosen({"prefilter", "--brdf", "phong:s=8"}), "prefilter");
  EXPECT_EQ(chosen({"--help", "ibl"}), "ibl");
  EXPECT_EQ(chosen({"sky", "info"}), "sky");  // one subcommand per command line
  EXPECT_EQ(chosen({"--version"}), "(none)");
  EXPECT_EQ(chosen({}), "(none)");
  EXPECT_EQ(chosen({"prefilterx"}), "(none)");
  EXPECT_EQ(chosen({"bogus", "prefilter"}), "(none)");  // CLI11 refuses "bogus" first
}

// Each declared option's manifest example, in the "options" of `base`, reaches the job that
// `job_of` reads from the parsed BatchJob; undeclared ones are refused.
template <typename Option, typename JobOf>
void CheckManifest(std::span<const Option> table, const nlohmann::json& base, const JobOf& job_of) {
  for (const Option& o : table) {
    nlohmann::json m = base;
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
    EXPECT_TRUE(job_of(jobs[0]) == WithExample(o)) << o.name << ": did not reach the job";
  }
}

TEST(JobFrontEnds, ManifestCarriesEveryDeclaredOptionAndRefusesTheOthers) {
  CheckManifest(jobs::PrefilterJobOptions(),
                {{"maps", {kMap}}, {"brdfs", {kBrdf}}, {"output", "o.shrm.exr"}},
                [](const cli::BatchJob& j) { return j.job; });
  CheckManifest(jobs::IblJobOptions(), {{"kind", "ibl"}, {"maps", {kMap}}, {"output", "o_ibl"}},
                [](const cli::BatchJob& j) {
                  EXPECT_TRUE(j.ibl);
                  return j.ibl_job;
                });
  // And the prefilter manifest's own keys are only outputs. (In an IBL manifest "preview" is the
  // job's option: preview.png is one of the set's files, made wherever the job runs.)
  for (const std::string& key : kManifestOutputKeys) {
    EXPECT_EQ(jobs::FindPrefilterJobOption(key), nullptr) << key;
  }
  EXPECT_EQ(jobs::FindIblJobOption("report"), nullptr);
}

// Fake blob hashes for the job's files.
template <typename Job>
std::vector<std::string> Hashes(const Job& job) {
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

absl::StatusOr<shrm::v1::IblRequest> Encode(const IblJob& job) {
  shrm::v1::Environment env;
  absl::Status s = wire::EncodeEnvironment(job.env, Hashes(job), &env);
  if (!s.ok()) return s;
  return wire::EncodeIblRequest(job, env);
}

absl::StatusOr<wire::WirePrefilter> Decode(const shrm::v1::PrefilterRequest& req) {
  return wire::DecodePrefilterRequest(req);
}
absl::StatusOr<wire::WireIbl> Decode(const shrm::v1::IblRequest& req) {
  return wire::DecodeIblRequest(req);
}

template <typename Option>
void CheckWire(std::span<const Option> table) {
  for (const Option& o : table) {
    const auto job = WithExample(o);
    auto req = Encode(job);
    if (!(o.front_ends & jobs::kWire)) {
      EXPECT_EQ(req.status().code(), absl::StatusCode::kInvalidArgument) << o.name;
      continue;
    }
    ASSERT_TRUE(req.ok()) << o.name << ": " << req.status();
    auto back = Decode(*req);
    ASSERT_TRUE(back.ok()) << o.name << ": " << back.status();
    EXPECT_TRUE(back->job == job) << o.name << ": lost on the wire";
    EXPECT_EQ(back->sha256, Hashes(job));
  }
}

TEST(JobFrontEnds, WireCarriesEveryDeclaredOptionAndRefusesTheOthers) {
  CheckWire(jobs::PrefilterJobOptions());
  CheckWire(jobs::IblJobOptions());
}

// Every field of the request is written by some option (its encoding differs from the base
// job's) or is one of the inputs' fields: a field no option reaches is a forgotten option.
template <typename Option, typename Job>
void CheckWireFields(std::span<const Option> table, const Job& base_job) {
  const auto base = Encode(base_job);
  ASSERT_TRUE(base.ok());
  std::set<std::string> reached;
  for (const Option& o : table) {
    if (!(o.front_ends & jobs::kWire)) continue;
    auto req = Encode(WithExample(o));
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
       {base->GetDescriptor(), shrm::v1::Environment::descriptor()}) {
    for (int i = 0; i < d->field_count(); ++i) {
      const std::string name = d->field(i)->name();
      if (name == "environment" || kWireInputFields.count(name)) continue;
      EXPECT_TRUE(reached.count(name)) << d->name() << "." << name << " carries no job option";
    }
  }
}

TEST(JobFrontEnds, WireHasNoFieldWithoutAnOption) {
  CheckWireFields(jobs::PrefilterJobOptions(), BaseJob());
  CheckWireFields(jobs::IblJobOptions(), IblBaseJob());
}

// The defaults are the job's on every front end (docs/shrm.md "Defaults": the tolerance rule at
// 1%, checked at 64 pairs): a command line, a manifest and a request that name no order rule and
// no check; and two order rules are refused by each.
TEST(JobFrontEnds, DefaultsAreTheJobsAndTwoOrderRulesAreRefused) {
  const PrefilterJob want = BaseJob();
  ASSERT_EQ(want.tolerance, jobs::kDefaultTolerance);
  ASSERT_EQ(want.verify, jobs::kDefaultVerify);
  absl::StatusOr<PrefilterJob> cli_job = cli::ParsePrefilterCommandLine(
      {"prefilter", "-o", "x.shrm.exr", "--brdf", kBrdf, "--env", kMap});
  ASSERT_TRUE(cli_job.ok()) << cli_job.status();
  EXPECT_TRUE(*cli_job == want);
  const nlohmann::json manifest = {{"maps", {kMap}}, {"brdfs", {kBrdf}}, {"output", "o.shrm.exr"}};
  cli::BatchOptions options;
  std::vector<cli::BatchJob> jobs;
  std::vector<std::string> errors;
  cli::ParseManifest(manifest, "", &options, &jobs, &errors);
  ASSERT_TRUE(errors.empty()) << errors[0];
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_TRUE(jobs[0].job == want);
  // The wire: neither order field nor verify in the request.
  shrm::v1::PrefilterRequest req;
  ASSERT_TRUE(wire::EncodeEnvironment(want.env, Hashes(want), req.mutable_environment()).ok());
  req.set_brdf(kBrdf);
  absl::StatusOr<wire::WirePrefilter> wire_job = Decode(req);
  ASSERT_TRUE(wire_job.ok()) << wire_job.status();
  EXPECT_TRUE(wire_job->job == want);
  // A tolerance of 0 on the wire is refused, not read as "the epsilon rule".
  req.set_tolerance(0);
  EXPECT_EQ(Decode(req).status().code(), absl::StatusCode::kInvalidArgument);

  // Two rules: refused on the command line and in a manifest (the wire's oneof holds one).
  absl::StatusOr<PrefilterJob> two =
      cli::ParsePrefilterCommandLine({"prefilter", "-o", "x.shrm.exr", "--brdf", kBrdf, "--env",
                                      kMap, "--epsilon", "0.03", "--orders", "8,1"});
  EXPECT_EQ(two.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(two.status().message().find("--epsilon, --tolerance and --orders exclude each other"),
            std::string::npos)
      << two.status();
  nlohmann::json both = manifest;
  both["options"] = {{"epsilon", 0.03}, {"tolerance", 0.01}};
  jobs.clear();
  cli::ParseManifest(both, "", &options, &jobs, &errors);
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("exclude each other"), std::string::npos) << errors[0];
}

// Found by fuzzing (docs/fuzzing.md): nlohmann's parser throws out_of_range, not parse_error, for a
// number beyond double ("1e400"); `shrm batch` caught only parse_error and terminated.
TEST(BatchManifest, NumberOutOfRangeIsNotJsonRatherThanACrash) {
  absl::StatusOr<nlohmann::json> m =
      cli::ParseManifestText(R"({"maps": ["map.exr"], "brdfs": ["lambert"], "output": 1e400})");
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(m.status().message().find("not JSON"), std::string::npos) << m.status();
  EXPECT_EQ(cli::ParseManifestText("{\"maps\": [").status().code(),
            absl::StatusCode::kInvalidArgument);
  absl::StatusOr<nlohmann::json> ok = cli::ParseManifestText(R"({"maps": ["map.exr"]})");
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ((*ok)["maps"][0], "map.exr");
}

}  // namespace
}  // namespace shrm
