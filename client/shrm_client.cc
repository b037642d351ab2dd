#include "client/shrm_client.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/io/sha256.h"
#include "proto/status_details.h"

namespace shrm::client {
namespace {

namespace v1 = ::shrm::v1;

// Upload chunk size: 1 MiB, a quarter of gRPC's default 4 MiB message limit.
constexpr size_t kUploadChunkBytes = 1 << 20;
// Largest up-front reservation for a downloaded SHRM file (larger files still arrive, growing).
constexpr uint64_t kMaxReserveBytes = uint64_t{256} << 20;

void SetDeadline(grpc::ClientContext* context, absl::Duration d) {
  if (d == absl::InfiniteDuration()) return;
  context->set_deadline(absl::ToChronoTime(absl::Now() + d));
}

void FromEnv(std::string* field, const char* name) {
  if (!field->empty()) return;
  const char* v = std::getenv(name);
  if (v != nullptr) *field = v;
}

absl::StatusOr<std::string> ReadPem(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InvalidArgumentError(absl::StrCat(what, ": cannot read ", path));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The first non-blank line of `path` not starting with '#' (error messages never show it).
absl::StatusOr<std::string> ReadToken(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("token file: cannot read ", path));
  std::string line;
  while (std::getline(in, line)) {
    absl::string_view t = absl::StripAsciiWhitespace(line);
    if (!t.empty() && t.front() != '#') return std::string(t);
  }
  return absl::InvalidArgumentError(absl::StrCat("token file: no token in ", path));
}

// A file received in chunks (FileChunk): appended in order, hashed as it arrives, checked
// against the SHA-256 of its last chunk. `what` names it in errors ("SHRM file").
class FileAssembler {
 public:
  explicit FileAssembler(std::string what) : what_(std::move(what)) {}
  // DataLoss when the chunk does not continue the file.
  absl::Status Add(const v1::FileChunk& chunk) {
    if (chunk.offset() != bytes_.size() || have_last_) {
      return absl::DataLossError(absl::StrCat(what_, " chunks out of order"));
    }
    if (chunk.offset() == 0 && chunk.total_size() > 0) {
      // A hint from the server: capped, so a bad value cannot exhaust memory up front.
      bytes_.reserve(std::min<uint64_t>(chunk.total_size(), kMaxReserveBytes));
    }
    bytes_ += chunk.data();
    sha_.Update(chunk.data());
    if (chunk.last()) {
      have_last_ = true;
      expected_sha_ = chunk.sha256();
    }
    return absl::OkStatus();
  }
  // The file's SHA-256; DataLoss unless it arrived whole with the hash its last chunk names.
  absl::StatusOr<std::string> Finish() {
    if (!have_last_)
      return absl::DataLossError(absl::StrCat("the ", what_, " transfer was incomplete"));
    std::string got = sha_.Hex();
    if (got != expected_sha_) {
      return absl::DataLossError(
          absl::StrCat(what_, " SHA-256 mismatch: got ", got, ", server said ", expected_sha_));
    }
    return got;
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string what_;
  std::string bytes_;
  Sha256Stream sha_;
  bool have_last_ = false;
  std::string expected_sha_;
};

// Reads a streaming call's events into `on_event` (which returns an error to stop): sets
// *answered at the first event, cancels the call once *cancel is set or on an error.
template <typename Event, typename OnEvent>
absl::Status ReadEvents(grpc::ClientReader<Event>* reader, grpc::ClientContext* context,
                        const std::atomic<bool>* cancel, bool* answered, const OnEvent& on_event) {
  Event ev;
  while (reader->Read(&ev)) {
    *answered = true;
    if (cancel != nullptr && cancel->load()) context->TryCancel();
    if (absl::Status s = on_event(ev); !s.ok()) {
      context->TryCancel();
      return s;
    }
  }
  return absl::OkStatus();
}

// The progress and report events of a job stream (true when `ev` was one of them).
template <typename Event, typename Report>
bool ProgressOrReport(const Event& ev, const ProgressCallback& progress, Report* report,
                      bool* have_report) {
  if (ev.has_progress()) {
    if (progress) progress(ev.progress());
    return true;
  }
  if (!ev.has_report()) return false;
  *report = ev.report();
  *have_report = true;
  return true;
}

}  // namespace

bool IsTransient(const absl::Status& status) {
  if (absl::IsUnavailable(status)) return true;
  // INTERNAL / UNKNOWN from the transport or a proxy (a replica died mid-call: RST_STREAM,
  // GOAWAY, HTTP 502/503/504) carry no shrm ErrorInfo; the server's own carry one and are final.
  return (absl::IsInternal(status) || absl::IsUnknown(status)) && !wire::FromShrmServer(status);
}

bool IsDroppedCall(const absl::Status& status) {
  return absl::IsCancelled(status) && !wire::FromShrmServer(status);
}

bool IsMissingBlob(const absl::Status& status) {
  return absl::IsNotFound(status) && wire::ErrorReason(status) == wire::kReasonBlobNotFound;
}

absl::Duration ServerRetryDelay(const absl::Status& status) {
  if (!absl::IsResourceExhausted(status)) return absl::ZeroDuration();
  return wire::RetryDelay(status).value_or(absl::ZeroDuration());
}

absl::Duration RetryBackoff(const ClientOptions& options, int attempt) {
  absl::Duration d = options.initial_backoff;
  for (int i = 1; i < attempt && d < options.max_backoff; ++i) d *= 2;
  return std::min(d, options.max_backoff);
}

absl::StatusOr<std::unique_ptr<ShrmClient>> ShrmClient::Connect(const std::string& target,
                                                                const ClientOptions& options) {
  if (target.empty()) return absl::InvalidArgumentError("server target: empty");
  if (options.max_attempts < 1) return absl::InvalidArgumentError("max_attempts must be >= 1");
  ClientOptions opt = options;
  FromEnv(&opt.token_file, "SHRM_TOKEN_FILE");
  FromEnv(&opt.tls_ca_file, "SHRM_TLS_CA");
  FromEnv(&opt.tls_cert_file, "SHRM_TLS_CERT");
  FromEnv(&opt.tls_key_file, "SHRM_TLS_KEY");
  if (opt.token.empty() && !opt.token_file.empty()) {
    absl::StatusOr<std::string> token = ReadToken(opt.token_file);
    if (!token.ok()) return token.status();
    opt.token = *std::move(token);
  }
  if (opt.tls_cert_file.empty() != opt.tls_key_file.empty()) {
    return absl::InvalidArgumentError(
        "tls_cert_file and tls_key_file go together (a client certificate needs its key)");
  }
  grpc::ChannelArguments args;
  args.SetLoadBalancingPolicyName("round_robin");
  if (opt.own_connection) args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  std::shared_ptr<grpc::ChannelCredentials> creds;
  if (!opt.tls_ca_file.empty() || !opt.tls_cert_file.empty()) {
    grpc::SslCredentialsOptions ssl;
    if (!opt.tls_ca_file.empty()) {
      absl::StatusOr<std::string> ca = ReadPem(opt.tls_ca_file, "TLS CA file");
      if (!ca.ok()) return ca.status();
      ssl.pem_root_certs = *ca;
    }
    if (!opt.tls_cert_file.empty()) {
      absl::StatusOr<std::string> cert = ReadPem(opt.tls_cert_file, "TLS certificate file");
      if (!cert.ok()) return cert.status();
      absl::StatusOr<std::string> key = ReadPem(opt.tls_key_file, "TLS key file");
      if (!key.ok()) return key.status();
      ssl.pem_cert_chain = *cert;
      ssl.pem_private_key = *key;
    }
    creds = grpc::SslCredentials(ssl);
    if (!opt.tls_server_name.empty()) args.SetSslTargetNameOverride(opt.tls_server_name);
  } else if (!opt.token.empty()) {
    creds = grpc::experimental::LocalCredentials(LOCAL_TCP);
  } else {
    creds = grpc::InsecureChannelCredentials();
  }
  std::shared_ptr<grpc::Channel> channel = grpc::CreateCustomChannel(target, creds, args);
  if (!channel) return absl::InvalidArgumentError(absl::StrCat("server target: bad: ", target));
  return std::unique_ptr<ShrmClient>(new ShrmClient(std::move(channel), opt));
}

ShrmClient::ShrmClient(std::shared_ptr<grpc::Channel> channel, const ClientOptions& options)
    : channel_(std::move(channel)), stub_(v1::Shrm::NewStub(channel_)), options_(options) {}

void ShrmClient::Authorize(grpc::ClientContext* context) const {
  if (!options_.token.empty()) context->AddMetadata("authorization", "Bearer " + options_.token);
  if (!affinity_key_.empty()) context->AddMetadata("x-shrm-affinity", affinity_key_);
}

absl::Status ShrmClient::WithRetries(
    const std::function<grpc::Status(grpc::ClientContext*)>& attempt, absl::Duration deadline) {
  absl::Status status;
  for (int i = 0; i < options_.max_attempts; ++i) {
    if (i > 0) absl::SleepFor(RetryBackoff(options_, i));
    grpc::ClientContext context;
    SetDeadline(&context, std::min(deadline, options_.call_timeout));
    Authorize(&context);
    status = Received(attempt(&context));
    // These calls never cancel themselves, so a CANCELLED without ErrorInfo was dropped.
    if (!IsTransient(status) && !IsDroppedCall(status)) break;
  }
  return status;
}

absl::Status ShrmClient::Received(const grpc::Status& status) {
  absl::Status s = wire::FromGrpcStatus(status);
  last_retry_after_ms_ = absl::ToInt64Milliseconds(ServerRetryDelay(s));
  return s;
}

absl::StatusOr<v1::HasBlobResponse> ShrmClient::HasBlob(const std::string& sha256) {
  v1::HasBlobRequest req;
  req.set_sha256(sha256);
  return Unary(&v1::Shrm::Stub::HasBlob, req, absl::InfiniteDuration());
}

grpc::Status ShrmClient::UploadOnce(grpc::ClientContext* context, std::string_view bytes,
                                    const std::string& sha256, std::string* verified) {
  v1::UploadBlobResponse resp;
  std::unique_ptr<grpc::ClientWriter<v1::UploadBlobChunk>> writer =
      stub_->UploadBlob(context, &resp);
  size_t offset = 0;
  bool first = true;
  while (first || offset < bytes.size()) {
    v1::UploadBlobChunk chunk;
    if (first) {
      chunk.set_sha256(sha256);
      chunk.set_total_size(bytes.size());
      first = false;
    }
    const size_t n = std::min(kUploadChunkBytes, bytes.size() - offset);
    chunk.set_data(bytes.data() + offset, n);
    offset += n;
    if (!writer->Write(chunk)) break;  // the server ended the call: Finish() says why
  }
  writer->WritesDone();
  grpc::Status status = writer->Finish();
  if (status.ok()) *verified = resp.sha256();
  return status;
}

absl::StatusOr<std::string> ShrmClient::UploadBytes(std::string_view bytes) {
  const std::string sha = Sha256Hex(bytes);
  std::string verified;
  absl::Status s =
      WithRetries([&](grpc::ClientContext* c) { return UploadOnce(c, bytes, sha, &verified); },
                  absl::InfiniteDuration());
  if (!s.ok()) return s;
  if (verified != sha) {
    return absl::DataLossError(
        absl::StrCat("upload: server verified ", verified, ", expected ", sha));
  }
  return sha;
}

absl::StatusOr<RemoteBrdf> ResolveRemoteBrdf(const std::string& spec, ShrmClient* client) {
  RemoteBrdf out;
  out.spec = spec;
  // As core's ParseBrdfSpec reads the spec: TableBrdf/MerlBrdf::spec() is "<model>:<path>".
  std::string model;
  const std::optional<std::string> path = BrdfSpecFile(spec, &model);
  if (!path || path->empty() || *path == "@") return out;
  absl::StatusOr<std::string> sha = client->UploadIfMissing(*path);
  if (!sha.ok()) {
    return WithMessage(sha.status(),
                       absl::StrCat("BRDF ", model, " file ", *path, ": ", sha.status().message()));
  }
  out.spec = absl::StrCat(model, ":@");
  out.blob_sha256 = *sha;
  out.display_spec = absl::StrCat(model, ":", *path);
  return out;
}

absl::StatusOr<std::string> ShrmClient::UploadIfMissing(const std::string& path) {
  absl::StatusOr<std::string> sha = FileSha256(path);
  if (!sha.ok()) {
    // The callers name the file ("<path>: ..."); Sha256OfFile's message names it too.
    const std::string named = absl::StrCat(path, ": ");
    if (!absl::StartsWith(sha.status().message(), named)) return sha.status();
    return WithMessage(sha.status(), std::string(sha.status().message().substr(named.size())));
  }
  if (upload_copies_ <= 0) {
    absl::StatusOr<v1::HasBlobResponse> has = HasBlob(*sha);
    if (!has.ok()) return has.status();
    if (has->present()) return *sha;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (int copy = 0; copy < std::max(1, upload_copies_); ++copy) {
    absl::StatusOr<std::string> up = UploadBytes(bytes);
    if (!up.ok()) return up.status();
    if (*up != *sha) return absl::DataLossError(absl::StrCat(path, ": changed while uploading"));
  }
  return *sha;
}

template <typename Request, typename Outcome>
absl::StatusOr<Outcome> ShrmClient::SendUntilAnswered(OnceCall<Request, Outcome> once,
                                                      const Request& request,
                                                      const ProgressCallback& progress,
                                                      absl::Duration deadline,
                                                      const std::atomic<bool>* cancel) {
  absl::StatusOr<Outcome> r;
  for (int i = 0; i < options_.max_attempts; ++i) {
    if (i > 0) {
      absl::SleepFor(RetryBackoff(options_, i));
      ++resent_calls_;
    }
    bool answered = false;
    r = (this->*once)(request, progress, deadline, cancel, &answered);
    // Sent again only when it failed in the transport before any answer of a server (a fresh
    // connection dropped on a loaded machine, a call a shutting-down server dropped unstarted);
    // everything else is the caller's to decide.
    if (r.ok() || answered || wire::FromShrmServer(r.status()) ||
        !(IsTransient(r.status()) || IsDroppedCall(r.status())) ||
        (cancel != nullptr && cancel->load())) {
      break;
    }
  }
  return r;
}

absl::StatusOr<PrefilterOutcome> ShrmClient::Prefilter(const v1::PrefilterRequest& request,
                                                       const ProgressCallback& progress,
                                                       absl::Duration deadline,
                                                       const std::atomic<bool>* cancel) {
  return SendUntilAnswered(&ShrmClient::PrefilterOnce, request, progress, deadline, cancel);
}

absl::StatusOr<IblCallOutcome> ShrmClient::Ibl(const v1::IblRequest& request,
                                               const ProgressCallback& progress,
                                               absl::Duration deadline,
                                               const std::atomic<bool>* cancel) {
  return SendUntilAnswered(&ShrmClient::IblOnce, request, progress, deadline, cancel);
}

absl::StatusOr<std::unique_ptr<LiveCall>> ShrmClient::OpenLive(const v1::LiveOpen& open,
                                                               absl::Duration deadline) {
  std::unique_ptr<LiveCall> call(new LiveCall());
  SetDeadline(&call->context_, deadline);
  Authorize(&call->context_);
  call->stream_ = stub_->Live(&call->context_);
  call->view_only_ = open.view_only();
  v1::LiveRequest request;
  *request.mutable_open() = open;
  if (!call->stream_->Write(request)) {
    const absl::Status s = call->Finish();
    return s.ok() ? absl::UnavailableError("the live call ended before it was opened") : s;
  }
  return call;
}

absl::StatusOr<std::optional<LiveFrameOutcome>> LiveCall::Next() {
  v1::LiveEvent ev;
  std::optional<LiveFrameOutcome> out;
  FileAssembler file("live frame"), view_file("live view map");
  std::optional<FileAssembler> ibl_file;
  bool file_done = view_only_, view_done = true;
  uint32_t ibl_expected = 0;
  while (stream_->Read(&ev)) {
    if (!out) {
      file_done = file_done || ev.no_shrm();
      ibl_expected = ev.ibl_files();
      out.emplace();
      out->update = ev.update();
      out->dropped = ev.dropped();
      out->f_b = ev.f_b();
      out->p_b = ev.p_b();
      out->timings.assign(ev.timings().begin(), ev.timings().end());
      if (ev.has_view()) {
        out->view = std::array<double, 3>{ev.view().x(), ev.view().y(), ev.view().z()};
        view_done = false;
      }
    } else if (ev.update() != out->update) {
      return absl::DataLossError("a live frame's chunks belong to two updates");
    }
    if (ev.has_shrm_file()) {
      if (file_done) return absl::DataLossError("a live frame has an unexpected SHRM file chunk");
      SHRM_RETURN_IF_ERROR(file.Add(ev.shrm_file()));
      if (ev.shrm_file().last()) {
        SHRM_RETURN_IF_ERROR(file.Finish().status());
        out->shrm_file = std::move(file.bytes());
        file_done = true;
      }
    } else if (ev.has_view_file()) {
      if (view_done) return absl::DataLossError("a live frame has an unexpected view map chunk");
      SHRM_RETURN_IF_ERROR(view_file.Add(ev.view_file()));
      if (ev.view_file().last()) {
        SHRM_RETURN_IF_ERROR(view_file.Finish().status());
        out->view_file = std::move(view_file.bytes());
        view_done = true;
      }
    } else if (ev.has_ibl_file()) {
      if (!file_done || !view_done || out->ibl_files.size() >= ibl_expected) {
        return absl::DataLossError("a live frame has an unexpected split-sum file chunk");
      }
      if (!ibl_file) {
        ibl_file.emplace(absl::StrCat("live split-sum file ", ev.ibl_file().name()));
        out->ibl_files.push_back({ev.ibl_file().name(), "", ""});
      } else if (ev.ibl_file().name() != out->ibl_files.back().name) {
        return absl::DataLossError("a live split-sum file's chunks carry two names");
      }
      SHRM_RETURN_IF_ERROR(ibl_file->Add(ev.ibl_file().chunk()));
      if (ev.ibl_file().chunk().last()) {
        SHRM_ASSIGN_OR_RETURN(out->ibl_files.back().sha256, ibl_file->Finish());
        out->ibl_files.back().bytes = std::move(ibl_file->bytes());
        ibl_file.reset();
      }
    } else {
      return absl::DataLossError("a live event without a file chunk");
    }
    if (file_done && view_done && !ibl_file && out->ibl_files.size() == ibl_expected) return out;
  }
  if (out) return absl::DataLossError("the live call ended inside a frame");
  return std::optional<LiveFrameOutcome>();
}

absl::Status LiveCall::Finish() { return wire::FromGrpcStatus(stream_->Finish()); }

absl::StatusOr<PrefilterOutcome> ShrmClient::PrefilterOnce(const v1::PrefilterRequest& request,
                                                           const ProgressCallback& progress,
                                                           absl::Duration deadline,
                                                           const std::atomic<bool>* cancel,
                                                           bool* answered) {
  grpc::ClientContext context;
  SetDeadline(&context, deadline);
  Authorize(&context);
  std::unique_ptr<grpc::ClientReader<v1::PrefilterEvent>> reader =
      stub_->Prefilter(&context, request);
  PrefilterOutcome out;
  bool have_report = false;
  FileAssembler file("SHRM file");
  const absl::Status read =
      ReadEvents(reader.get(), &context, cancel, answered, [&](const v1::PrefilterEvent& ev) {
        if (ProgressOrReport(ev, progress, &out.report, &have_report) || !ev.has_shrm_file()) {
          return absl::OkStatus();
        }
        return file.Add(ev.shrm_file());
      });
  if (!read.ok()) return read;
  const absl::Status status = Received(reader->Finish());
  if (!status.ok()) return status;
  const bool want_file =
      request.outputs_size() == 0 || std::find(request.outputs().begin(), request.outputs().end(),
                                               v1::OUTPUT_SHRM_FILE) != request.outputs().end();
  if (!have_report) return absl::DataLossError("the server sent no report");
  if (want_file) {
    SHRM_ASSIGN_OR_RETURN(out.shrm_sha256, file.Finish());
    out.shrm_file = std::move(file.bytes());
  }
  return out;
}

absl::StatusOr<IblCallOutcome> ShrmClient::IblOnce(const v1::IblRequest& request,
                                                   const ProgressCallback& progress,
                                                   absl::Duration deadline,
                                                   const std::atomic<bool>* cancel,
                                                   bool* answered) {
  grpc::ClientContext context;
  SetDeadline(&context, deadline);
  Authorize(&context);
  std::unique_ptr<grpc::ClientReader<v1::IblEvent>> reader = stub_->Ibl(&context, request);
  IblCallOutcome out;
  bool have_report = false;
  std::optional<FileAssembler> file;  // the file arriving now
  std::string name;
  // Ends the file arriving now (verified) and adds it to the outcome.
  auto finish_file = [&]() -> absl::Status {
    if (!file) return absl::OkStatus();
    SHRM_ASSIGN_OR_RETURN(std::string sha, file->Finish());
    out.files.push_back({name, std::move(file->bytes()), std::move(sha)});
    file.reset();
    return absl::OkStatus();
  };
  const absl::Status read =
      ReadEvents(reader.get(), &context, cancel, answered, [&](const v1::IblEvent& ev) {
        if (ProgressOrReport(ev, progress, &out.report, &have_report) || !ev.has_file()) {
          return absl::OkStatus();
        }
        if (!file || ev.file().name() != name) {
          SHRM_RETURN_IF_ERROR(finish_file());
          name = ev.file().name();
          file.emplace(name);
        }
        return file->Add(ev.file().chunk());
      });
  if (!read.ok()) return read;
  const absl::Status status = Received(reader->Finish());
  if (!status.ok()) return status;
  if (!have_report) return absl::DataLossError("the server sent no report");
  SHRM_RETURN_IF_ERROR(finish_file());
  bool listed = out.files.size() == static_cast<size_t>(out.report.files_size());
  for (size_t i = 0; listed && i < out.files.size(); ++i) {
    listed = out.files[i].name == out.report.files(i).name() &&
             out.files[i].bytes.size() == out.report.files(i).size();
  }
  if (!listed) {
    return absl::DataLossError(absl::StrCat("the server sent ", out.files.size(),
                                            " files, not the ", out.report.files_size(),
                                            " its report lists"));
  }
  return out;
}

absl::StatusOr<v1::AnalyzeResponse> ShrmClient::Analyze(const v1::AnalyzeRequest& request,
                                                        absl::Duration deadline) {
  return Unary(&v1::Shrm::Stub::Analyze, request, deadline);
}

absl::StatusOr<v1::ReferenceResponse> ShrmClient::Reference(const v1::ReferenceRequest& request,
                                                            absl::Duration deadline) {
  return Unary(&v1::Shrm::Stub::Reference, request, deadline);
}

absl::StatusOr<v1::IrradianceResponse> ShrmClient::Irradiance(const v1::IrradianceRequest& request,
                                                              absl::Duration deadline) {
  return Unary(&v1::Shrm::Stub::Irradiance, request, deadline);
}

absl::StatusOr<v1::ListBrdfModelsResponse> ShrmClient::ListBrdfModels() {
  return Unary(&v1::Shrm::Stub::ListBrdfModels, v1::ListBrdfModelsRequest(),
               absl::InfiniteDuration());
}

absl::StatusOr<std::string> ShrmClient::FileSha256(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  const auto mtime = std::filesystem::last_write_time(path, ec);
  if (!ec) {
    auto it = file_hashes_.find(path);
    if (it != file_hashes_.end() && it->second.size == size && it->second.mtime == mtime) {
      return it->second.sha256;
    }
  }
  absl::StatusOr<std::string> sha = Sha256OfFile(path);
  if (sha.ok() && !ec) file_hashes_[path] = {size, mtime, *sha};
  return sha;
}

}  // namespace shrm::client
