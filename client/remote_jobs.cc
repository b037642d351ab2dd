#include "client/remote_jobs.h"

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/time/clock.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "proto/job_codec.h"

namespace shrm::client {

absl::Status UploadEnvironment(const jobs::EnvironmentSpec& env, ShrmClient* client,
                               shrm::v1::Environment* out) {
  SHRM_RETURN_IF_ERROR(wire::CheckRemoteEnvironment(env));  // before any upload
  std::vector<std::string> hashes;
  for (const std::string& f : env.files) {
    absl::StatusOr<std::string> sha = client->UploadIfMissing(f);
    if (!sha.ok()) return WithMessage(sha.status(), absl::StrCat(f, ": ", sha.status().message()));
    hashes.push_back(*std::move(sha));
  }
  return wire::EncodeEnvironment(env, hashes, out);
}

std::string NameUploadedFiles(std::string message,
                              const std::vector<std::pair<std::string, std::string>>& files) {
  for (const auto& [path, sha] : files) {
    // The server calls a BRDF file "BRDF blob <sha>" where the embedded run names the path.
    message = absl::StrReplaceAll(message, {{absl::StrCat("BRDF blob ", sha), path}});
    message = absl::StrReplaceAll(message, {{absl::StrCat("blob ", sha), path}});
  }
  return message;
}

absl::Status RunRemoteJob(ShrmClient* client, const jobs::EnvironmentSpec& env,
                          const std::string& target, const std::function<absl::Status()>& attempt,
                          const RetryCallback& on_retry, int* retries,
                          const std::vector<std::string>& other_files) {
  const int max_attempts = client->options().max_attempts;
  if (env.files.size() == 1) {
    absl::StatusOr<std::string> key = client->FileSha256(env.files[0]);
    if (key.ok()) client->set_affinity_key(*key);
  }
  int retried = 0, missing_blob_answers = 0;
  absl::Status s;
  for (int i = 0;; ++i) {
    if (i > 0) absl::SleepFor(RetryBackoff(client->options(), i));
    client->set_upload_copies(missing_blob_answers > 0 ? missing_blob_answers + 1 : 0);
    const int resent_before = client->resent_calls();
    s = attempt();
    // A call the client library sent again by itself (broken before any answer) is a retry too.
    retried += client->resent_calls() - resent_before;
    const bool missing_blob = IsMissingBlob(s);
    // A full server (every job slot busy) says when to come back; an oversized input does not.
    const absl::Duration retry_after = ServerRetryDelay(s);
    if (s.ok() || i + 1 >= max_attempts ||
        !(IsTransient(s) || missing_blob || retry_after > absl::ZeroDuration())) {
      break;
    }
    absl::SleepFor(retry_after);
    ++retried;
    missing_blob_answers += missing_blob;
    if (on_retry) on_retry(s, i + 2, max_attempts);
  }
  if (retries != nullptr) *retries = retried;
  if (s.ok()) return s;
  std::vector<std::pair<std::string, std::string>> uploaded;
  for (const std::vector<std::string>* files : {&env.files, &other_files}) {
    for (const std::string& f : *files) {
      absl::StatusOr<std::string> sha = client->FileSha256(f);  // cached since the upload
      if (sha.ok()) uploaded.emplace_back(f, *sha);
    }
  }
  const std::string message = NameUploadedFiles(std::string(s.message()), uploaded);
  return WithMessage(s, absl::StrCat(target, ": ", message,
                                     retried > 0 ? absl::StrCat(" (after ", retried, " retries)")
                                                 : std::string()));
}

std::vector<std::string> BrdfFiles(const std::string& spec) {
  std::optional<std::string> file = BrdfSpecFile(spec);
  return file ? std::vector<std::string>{*file} : std::vector<std::string>{};
}

absl::StatusOr<RemotePrefilterResult> RunRemotePrefilter(ShrmClient* client,
                                                         const std::string& target,
                                                         const jobs::PrefilterJob& job,
                                                         const RemotePrefilterOptions& options,
                                                         int* retries) {
  SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(job));
  RemotePrefilterResult out;
  const absl::Status s = RunRemoteJob(
      client, job.env, target,
      [&]() -> absl::Status {
        if (options.on_upload_start) options.on_upload_start();
        shrm::v1::Environment env;
        absl::Status uploaded = UploadEnvironment(job.env, client, &env);
        // table:PATH / merl:PATH: the file travels as a blob; shrm:brdf records the local spec.
        absl::StatusOr<RemoteBrdf> brdf =
            uploaded.ok() ? ResolveRemoteBrdf(job.brdf, client) : uploaded;
        if (options.on_upload_end) options.on_upload_end();
        if (!brdf.ok()) return brdf.status();
        SHRM_ASSIGN_OR_RETURN(
            out.outcome,
            client->Prefilter(wire::EncodePrefilterRequest(job, env, *brdf, options.report_visuals),
                              options.progress));
        return absl::OkStatus();
      },
      options.on_retry, &out.retries, BrdfFiles(job.brdf));
  if (retries != nullptr) *retries = out.retries;
  if (!s.ok()) return s;
  return out;
}

absl::StatusOr<RemoteIblResult> RunRemoteIbl(ShrmClient* client, const std::string& target,
                                             const jobs::IblJob& job,
                                             const RemoteJobOptions& options) {
  SHRM_RETURN_IF_ERROR(jobs::ValidateIblJob(job));
  RemoteIblResult out;
  const absl::Status s = RunRemoteJob(
      client, job.env, target,
      [&]() -> absl::Status {
        if (options.on_upload_start) options.on_upload_start();
        shrm::v1::Environment env;
        const absl::Status uploaded = UploadEnvironment(job.env, client, &env);
        if (options.on_upload_end) options.on_upload_end();
        SHRM_RETURN_IF_ERROR(uploaded);
        SHRM_ASSIGN_OR_RETURN(out.outcome,
                              client->Ibl(wire::EncodeIblRequest(job, env), options.progress));
        return absl::OkStatus();
      },
      options.on_retry, &out.retries);
  if (!s.ok()) return s;
  return out;
}

}  // namespace shrm::client
