// The IBL job on the service (shrm.v1.Ibl, docs/server.md): an in-process server on a loopback
// port, the client library and `shrm ibl --server` / `shrm batch --server` against the embedded
// run: every file byte for byte the same, the same exit code, and bad options refused with
// INVALID_ARGUMENT naming the request field. Small maps and sizes keep each job under seconds; no
// assertion depends on wall-clock time.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#include "core/io/image.h"
#include "core/io/sha256.h"
#include "jobs/ibl_job.h"
#include "jobs/ibl_outputs.h"
#include "nlohmann/json.hpp"
#include "proto/job_codec.h"
#include "proto/status_details.h"
#include "server/metrics.h"
#include "server/server.h"
#include "tests/stage_gate.h"
#include "tests/test_maps.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::shrm::v1;

// The bundled map box-filtered to 128 x 64: the job's cost is the pixel sums of its check.
constexpr int kMapWidth = 128;
// Sizes of the test jobs: a two-level chain at 32 (16 x 16 for the cheapest runs).
constexpr int kFaceSize = 32;
constexpr int kSmallFaceSize = 16;
// Safety net of the gate test (tests/stage_gate.h): a broken server fails instead of hanging.
// Not a timing claim: passing never depends on it.
constexpr absl::Duration kGateTimeout = absl::Seconds(60);

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class IblServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::UniqueTempPath("ibl_service");
    fs::create_directories(dir_);
    map_ = dir_ + "/courtyard_small.exr";
    ASSERT_TRUE(WriteExr(map_, testing::LoadBundledMap("courtyard.exr", kMapWidth)).ok());
    server::ServerOptions opt;
    opt.service.max_jobs = 2;
    StartServer(opt);
  }
  // (Re)starts the server with `opt` (a fresh spool) and connects client_.
  void StartServer(server::ServerOptions opt) {
    client_.reset();
    server_.reset();
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = absl::StrCat(dir_, "/spool", ++servers_);
    opt.service.job_threads = 2;
    absl::StatusOr<std::unique_ptr<server::ShrmServer>> s = server::ShrmServer::Start(opt);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    target_ = absl::StrCat("127.0.0.1:", server_->port());
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c = client::ShrmClient::Connect(target_);
    ASSERT_TRUE(c.ok()) << c.status();
    client_ = std::move(*c);
  }
  void TearDown() override {
    server_.reset();
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  jobs::IblJob Job() const {
    jobs::IblJob job;
    job.env.files = {map_};
    job.face_size = kFaceSize;
    job.sheen = true;
    job.irradiance_size = 8;
    job.dfg_size = 16;
    job.verify = 4;
    job.containers = {jobs::IblContainer::kKtx2, jobs::IblContainer::kKtx1,
                      jobs::IblContainer::kGltf};
    job.preview = true;
    return job;
  }

  // `shrm <args>` in the test folder; its exit code.
  int Shrm(const std::string& args) const {
    return std::system(
        absl::StrCat("cd ", dir_, " && ", SHRM_CLI_PATH, " ", args, " > /dev/null 2>&1").c_str());
  }

  int servers_ = 0;
  std::string dir_, map_, target_;
  std::unique_ptr<server::ShrmServer> server_;
  std::unique_ptr<client::ShrmClient> client_;
};

// Every file of `a` equals the same file of `b` (and both hold the same names).
void ExpectSameFolders(const std::string& a, const std::string& b) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(a)) names.push_back(e.path().filename().string());
  EXPECT_GE(names.size(), 4u) << a;
  for (const std::string& n : names) {
    const std::string x = ReadFile(a + "/" + n), y = ReadFile(b + "/" + n);
    EXPECT_FALSE(x.empty()) << n;
    EXPECT_TRUE(x == y) << n << " differs between " << a << " and " << b;
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(b), fs::directory_iterator()),
            static_cast<long>(names.size()));
}

TEST_F(IblServiceTest, RemoteFilesAreTheEmbeddedBytes) {
  jobs::IblJob job = Job();
  job.env.rotate_ypr_deg = std::array<double, 3>{30, 10, 0};
  // Embedded, with another thread count than the server's.
  absl::StatusOr<jobs::IblRun> run = jobs::RunIblJob(job, /*threads=*/3);
  ASSERT_TRUE(run.ok()) << run.status();
  absl::StatusOr<std::vector<jobs::IblFile>> embedded = jobs::EncodeIblOutputs(job, *run);
  ASSERT_TRUE(embedded.ok()) << embedded.status();

  std::vector<std::string> stages;
  client::RemoteJobOptions options;
  options.progress = [&](const v1::PrefilterProgress& p) { stages.push_back(p.stage()); };
  absl::StatusOr<client::RemoteIblResult> remote =
      client::RunRemoteIbl(client_.get(), target_, job, options);
  ASSERT_TRUE(remote.ok()) << remote.status();
  EXPECT_EQ(stages, (std::vector<std::string>{"decode", "lighting", "specular", "sheen",
                                              "irradiance", "dfg", "storage", "verify", "encode"}));
  const client::IblCallOutcome& out = remote->outcome;
  ASSERT_EQ(out.files.size(), embedded->size());
  for (size_t i = 0; i < embedded->size(); ++i) {
    const jobs::IblFile& e = (*embedded)[i];
    EXPECT_EQ(out.files[i].name, e.name);
    EXPECT_EQ(out.report.files(static_cast<int>(i)).what(), e.what);
    EXPECT_EQ(out.files[i].sha256, Sha256Hex(e.bytes)) << e.name;
    EXPECT_TRUE(out.files[i].bytes == e.bytes) << e.name << " differs from the embedded run's";
  }
  EXPECT_EQ(out.files.back().name, "ibl.json");
  // The report is the job's, and it records the client's file name, not the blob.
  EXPECT_EQ(nlohmann::json::parse(out.report.report_json()), run->report);
  EXPECT_EQ(out.report.source_sha256(), *Sha256OfFile(map_));
  EXPECT_NE(out.files.back().bytes.find(map_), std::string::npos);
}

// A specular.ktx2 larger than one chunk (1 MiB) arrives whole: rgba32f at 128 is ~2 MB.
TEST_F(IblServiceTest, IblCallsAreJobsAdmittedLikePrefilterAndCounted) {
  // The only slot is held by an Ibl job waiting at the gate: another one is refused at once with
  // the busy reason and a retry delay, then runs after the first; both are counted.
  server::ServerOptions opt;
  opt.service.max_jobs = 1;
  testing::StageGate gate;
  opt.service.test_stage_hook = gate.Hook();
  StartServer(opt);
  jobs::IblJob job = Job();
  job.face_size = kSmallFaceSize;
  v1::Environment env;
  ASSERT_TRUE(client::UploadEnvironment(job.env, client_.get(), &env).ok());
  const v1::IblRequest req = wire::EncodeIblRequest(job, env);
  const uint64_t ok_before = server::Metrics::Global().RequestCount("Ibl", "OK");
  absl::Status held;
  std::thread holder([&] { held = client_->Ibl(req).status(); });
  ASSERT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "the first job never reached a stage";
  absl::StatusOr<std::unique_ptr<client::ShrmClient>> other = client::ShrmClient::Connect(target_);
  ASSERT_TRUE(other.ok());
  absl::StatusOr<client::IblCallOutcome> busy = (*other)->Ibl(req, nullptr, kGateTimeout);
  EXPECT_EQ(busy.status().code(), absl::StatusCode::kResourceExhausted) << busy.status();
  EXPECT_EQ(wire::ErrorReason(busy.status()), wire::kReasonServerBusy);
  EXPECT_GT(client::ServerRetryDelay(busy.status()), absl::ZeroDuration());
  gate.Open();
  holder.join();
  EXPECT_TRUE(held.ok()) << held;
  EXPECT_TRUE((*other)->Ibl(req).ok());
  EXPECT_EQ(server::Metrics::Global().RequestCount("Ibl", "OK"), ok_before + 2);
  EXPECT_GE(server::Metrics::Global().RequestCount("Ibl", "RESOURCE_EXHAUSTED"), 1u);
}

TEST_F(IblServiceTest, FilesLargerThanOneChunkArriveWhole) {
  jobs::IblJob job = Job();
  job.face_size = 128;
  job.format = jobs::IblFormat::kRgba32f;
  job.sheen = false;
  job.verify = 0;
  absl::StatusOr<client::RemoteIblResult> remote =
      client::RunRemoteIbl(client_.get(), target_, job, {});
  ASSERT_TRUE(remote.ok()) << remote.status();
  ASSERT_FALSE(remote->outcome.files.empty());
  const client::ReceivedFile& specular = remote->outcome.files[0];
  EXPECT_EQ(specular.name, "specular.ktx2");
  EXPECT_GT(specular.bytes.size(), size_t{1} << 20);
  absl::StatusOr<jobs::IblRun> run = jobs::RunIblJob(job, 2);
  ASSERT_TRUE(run.ok()) << run.status();
  absl::StatusOr<std::vector<jobs::IblFile>> embedded = jobs::EncodeIblOutputs(job, *run);
  ASSERT_TRUE(embedded.ok());
  EXPECT_TRUE(specular.bytes == (*embedded)[0].bytes);
}

TEST_F(IblServiceTest, BadOptionsGetInvalidArgumentNamingTheField) {
  absl::StatusOr<std::string> sha = client_->UploadIfMissing(map_);
  ASSERT_TRUE(sha.ok()) << sha.status();
  auto request = [&] {
    v1::IblRequest req;
    req.mutable_environment()->add_sha256(*sha);
    req.set_face_size(kSmallFaceSize);
    return req;
  };
  struct Case {
    const char* field;
    v1::IblRequest req;
  };
  std::vector<Case> cases;
  cases.push_back({"face_size", request()});
  cases.back().req.set_face_size(24);
  cases.push_back({"levels", request()});
  cases.back().req.set_levels(9);
  cases.push_back({"roughness", request()});
  cases.back().req.add_roughness(0.5);  // with the filament preset
  cases.push_back({"roughness", request()});
  cases.back().req.set_preset(v1::IBL_PRESET_EXPLICIT);  // and no list
  cases.push_back({"tolerance", request()});
  cases.back().req.set_tolerance(2);
  cases.push_back({"verify", request()});
  cases.back().req.set_verify(jobs::kMaxIblVerify + 1);
  cases.push_back({"irradiance_size", request()});
  cases.back().req.set_irradiance_size(-1);
  cases.push_back({"dfg_size", request()});
  cases.back().req.set_dfg_size(jobs::kMaxDfgSize + 1);
  cases.push_back({"format", request()});
  cases.back().req.set_format(static_cast<v1::IblFormat>(99));
  cases.push_back({"sh_window", request()});
  cases.back().req.set_sh_window(static_cast<v1::IblShWindow>(99));
  cases.push_back({"environment.sha256", request()});
  cases.back().req.mutable_environment()->add_sha256(*sha);  // two blobs
  for (const Case& k : cases) {
    absl::StatusOr<client::IblCallOutcome> r = client_->Ibl(k.req);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument)
        << k.field << ": " << r.status();
    EXPECT_EQ(r.status().message().substr(0, std::string(k.field).size() + 1),
              absl::StrCat(k.field, ":"))
        << r.status();
    EXPECT_EQ(wire::ErrorReason(r.status()), "INVALID_ARGUMENT") << r.status();
  }
  // A missing map: NOT_FOUND with the reason clients upload again for.
  v1::IblRequest missing = request();
  missing.mutable_environment()->set_sha256(0, std::string(64, 'a'));
  absl::StatusOr<client::IblCallOutcome> r = client_->Ibl(missing);
  EXPECT_TRUE(client::IsMissingBlob(r.status())) << r.status();
  // And the server still serves (the zero fields take the job's defaults).
  v1::IblRequest good = request();
  good.set_irradiance_size(4);
  good.set_dfg_size(8);
  good.set_verify(0);
  r = client_->Ibl(good);
  ASSERT_TRUE(r.ok()) << r.status();
  const nlohmann::json report = nlohmann::json::parse(r->report.report_json());
  EXPECT_EQ(report["options"]["preset"], "filament");
  EXPECT_EQ(report["options"]["tolerance"], jobs::kDefaultIblTolerance);
  EXPECT_EQ(report["options"]["verify"], 0);
}

TEST_F(IblServiceTest, CliServerWritesTheEmbeddedFolderWithTheEmbeddedExitCode) {
  const std::string common =
      " --size 16 --sheen --irradiance-size 8 --dfg-size 16 --verify 4 --env courtyard_small.exr";
  const std::string server = " --server " + target_;
  ASSERT_EQ(Shrm("ibl" + common + " -o embedded"), 0);
  ASSERT_EQ(Shrm("ibl" + common + " -o remote" + server), 0);
  ExpectSameFolders(dir_ + "/embedded", dir_ + "/remote");
  // A tolerance the check must miss: exit 1 both ways, the files written all the same.
  const std::string strict = common + " --format rgba32f --tolerance 1e-7";
  EXPECT_EQ(WEXITSTATUS(Shrm("ibl" + strict + " -o strict_embedded")), 1);
  EXPECT_EQ(WEXITSTATUS(Shrm("ibl" + strict + " -o strict_remote" + server)), 1);
  ExpectSameFolders(dir_ + "/strict_embedded", dir_ + "/strict_remote");
  // A bad option fails before anything is sent or written.
  EXPECT_EQ(WEXITSTATUS(Shrm("ibl" + common + " --levels 9 -o never" + server)), 1);
  EXPECT_FALSE(fs::exists(dir_ + "/never"));
}

TEST_F(IblServiceTest, BatchManifestRunsIblJobsRemotelyWithTheEmbeddedBytesAndResumes) {
  fs::copy_file(map_, dir_ + "/second.exr");
  {
    std::ofstream m(dir_ + "/ibl.json");
    m << R"({"kind": "ibl", "maps": ["courtyard_small.exr", "second.exr"],
             "options": {"size": 16, "sheen": true, "irradiance_size": 8, "dfg_size": 16,
                         "verify": 4, "rotate": [90, 0, 0]},
             "output": "out/{map}_ibl"})";
  }
  const std::string server = " --server " + target_;
  ASSERT_EQ(Shrm("batch ibl.json --jobs 2" + server), 0);
  ASSERT_EQ(Shrm("ibl --size 16 --sheen --irradiance-size 8 --dfg-size 16 --verify 4 "
                 "--rotate 90,0,0 --env courtyard_small.exr -o single"),
            0);
  ExpectSameFolders(dir_ + "/single", dir_ + "/out/courtyard_small_ibl");
  EXPECT_TRUE(fs::exists(dir_ + "/out/second_ibl/specular.ktx2"));
  // Resume: both sets are up to date; another option recomputes them.
  const std::string summary = dir_ + "/summary.json";
  // The embedded batch's --json summary (exit 0 asserted).
  auto rerun = [&] {
    EXPECT_EQ(std::system(absl::StrCat("cd ", dir_, " && ", SHRM_CLI_PATH,
                                       " batch ibl.json --json > ", summary, " 2>/dev/null")
                              .c_str()),
              0);
    return nlohmann::json::parse(ReadFile(summary));
  };
  nlohmann::json s = rerun();
  EXPECT_EQ(s["skipped"], 2) << s.dump(1);
  EXPECT_EQ(s["jobs"][0]["kind"], "ibl");
  std::string manifest = ReadFile(dir_ + "/ibl.json");
  manifest.replace(manifest.find("\"verify\": 4"), 11, "\"verify\": 2");
  std::ofstream(dir_ + "/ibl.json") << manifest;
  s = rerun();
  EXPECT_EQ(s["ok"], 2) << s.dump(1);
  EXPECT_EQ(s["jobs"][1]["message"], "recomputed: other options");
  // A set an older revision of the rules chose is recomputed; one written before the revision
  // was recorded is revision 1.
  ASSERT_EQ(jobs::kIblRulesRevision, 1);
  auto edit_rules = [&](const std::string& set, std::optional<int> rules) {
    const std::string path = dir_ + "/out/" + set + "/ibl.json";
    nlohmann::json j = nlohmann::json::parse(ReadFile(path));
    ASSERT_EQ(j["rules"], jobs::kIblRulesRevision);
    if (rules)
      j["rules"] = *rules;
    else
      j.erase("rules");
    std::ofstream(path) << j.dump(1);
  };
  edit_rules("courtyard_small_ibl", 0);
  edit_rules("second_ibl", std::nullopt);
  s = rerun();
  EXPECT_EQ(s["ok"], 1) << s.dump(1);
  EXPECT_EQ(s["skipped"], 1) << s.dump(1);
  EXPECT_EQ(s["jobs"][0]["message"], "recomputed: chosen by older rules (rules 0 != 1)");
}

// The Live call with LiveOpen.ibl (docs/live.md): each frame carries the Ibl call's files for the
// frame's lighting, those of the embedded run with verify 0 byte for byte: the set alone before a
// BRDF, recomputed for a rotation, and beside the SHRM once a BRDF comes. Bad ibl options end the
// call at request 0 naming the field.
TEST_F(IblServiceTest, LiveFramesCarryTheSplitSumSetOfEachLightingState) {
  jobs::IblJob job = Job();
  job.verify = 0;
  auto embedded = [&](std::optional<std::array<double, 3>> rotate) {
    job.env.rotate_ypr_deg = rotate;
    absl::StatusOr<jobs::IblRun> run = jobs::RunIblJob(job, /*threads=*/1);
    EXPECT_TRUE(run.ok()) << run.status();
    if (!run.ok()) return std::vector<jobs::IblFile>{};
    absl::StatusOr<std::vector<jobs::IblFile>> files = jobs::EncodeIblOutputs(job, *run);
    EXPECT_TRUE(files.ok()) << files.status();
    return files.ok() ? *files : std::vector<jobs::IblFile>{};
  };
  auto expect_set = [](const client::LiveFrameOutcome& f, const std::vector<jobs::IblFile>& want) {
    ASSERT_EQ(f.ibl_files.size(), want.size());
    EXPECT_GE(want.size(), 5u);
    for (size_t i = 0; i < want.size(); ++i) {
      EXPECT_EQ(f.ibl_files[i].name, want[i].name);
      EXPECT_TRUE(f.ibl_files[i].bytes == want[i].bytes)
          << want[i].name << " differs from the embedded run's (update " << f.update << ")";
    }
  };
  v1::IblRequest ibl = wire::EncodeIblRequest(job, v1::Environment());
  ibl.clear_environment();
  ibl.clear_verify();
  absl::StatusOr<std::string> sha = client_->UploadIfMissing(map_);
  ASSERT_TRUE(sha.ok()) << sha.status();
  v1::LiveOpen open;
  open.set_face_size(kSmallFaceSize);
  *open.mutable_ibl() = ibl;
  absl::StatusOr<std::unique_ptr<client::LiveCall>> call = client_->OpenLive(open);
  ASSERT_TRUE(call.ok()) << call.status();
  client::LiveCall& live = **call;
  auto next = [&](uint64_t update) -> std::optional<client::LiveFrameOutcome> {
    for (;;) {
      absl::StatusOr<std::optional<client::LiveFrameOutcome>> f = live.Next();
      EXPECT_TRUE(f.ok()) << f.status();
      if (!f.ok() || !f->has_value()) return std::nullopt;
      if ((*f)->update >= update) return *f;
    }
  };
  v1::LiveRequest env;
  env.mutable_environment()->add_sha256(*sha);
  env.mutable_environment()->add_source_names(map_);
  ASSERT_TRUE(live.Send(env));
  std::optional<client::LiveFrameOutcome> f = next(1);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(f->shrm_file.empty());
  expect_set(*f, embedded(std::nullopt));
  v1::LiveRequest turn;
  turn.mutable_rotation()->set_yaw_deg(90);
  ASSERT_TRUE(live.Send(turn));
  f = next(2);
  ASSERT_TRUE(f.has_value());
  const std::vector<jobs::IblFile> turned = embedded(std::array<double, 3>{90, 0, 0});
  expect_set(*f, turned);
  v1::LiveRequest brdf;
  brdf.set_brdf("phong:s=32");
  ASSERT_TRUE(live.Send(brdf));
  ASSERT_TRUE(live.CloseSending());
  f = next(3);
  ASSERT_TRUE(f.has_value());
  EXPECT_FALSE(f->shrm_file.empty());
  expect_set(*f, turned);
  absl::StatusOr<std::optional<client::LiveFrameOutcome>> end = live.Next();
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_FALSE(end->has_value());
  EXPECT_TRUE(live.Finish().ok());

  // Bad ibl options: the call ends at request 0, naming the field; the server serves on.
  struct Bad {
    std::function<void(v1::IblRequest*)> change;
    std::string message_part;
  };
  const Bad bad[] = {
      {[&](v1::IblRequest* r) { r->mutable_environment()->add_sha256(*sha); }, "ibl.environment"},
      {[](v1::IblRequest* r) { r->set_verify(4); }, "ibl.verify"},
      {[](v1::IblRequest* r) { r->set_face_size(24); }, "ibl.face_size"},
  };
  for (const Bad& b : bad) {
    v1::LiveOpen o = open;
    b.change(o.mutable_ibl());
    absl::StatusOr<std::unique_ptr<client::LiveCall>> c = client_->OpenLive(o);
    ASSERT_TRUE(c.ok()) << c.status();
    (*c)->CloseSending();
    while (true) {
      absl::StatusOr<std::optional<client::LiveFrameOutcome>> x = (*c)->Next();
      if (!x.ok() || !x->has_value()) break;
    }
    const absl::Status s = (*c)->Finish();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
    EXPECT_NE(s.message().find("request 0"), std::string::npos) << s;
    EXPECT_NE(s.message().find(b.message_part), std::string::npos) << s;
  }
  EXPECT_TRUE(client_->HasBlob(*sha).ok());
}

// `shrm live --ibl --server` writes the embedded `shrm live --ibl`'s folders, byte for byte.
TEST_F(IblServiceTest, CliLiveRemoteWritesTheEmbeddedSplitSumSets) {
  const std::string common =
      absl::StrCat("live --env ", map_, " --turntable 2 --ibl --ibl-size 16 --ibl-preset gltf");
  ASSERT_EQ(Shrm(common + " -o live_local"), 0) << common;
  ASSERT_EQ(Shrm(absl::StrCat(common, " -o live_remote --server ", target_)), 0) << common;
  for (int k = 0; k < 2; ++k) {
    const std::string frame = absl::StrCat("/frame_000", k, ".ibl");
    ExpectSameFolders(dir_ + "/live_local" + frame, dir_ + "/live_remote" + frame);
  }
}

}  // namespace
}  // namespace shrm
