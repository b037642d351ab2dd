#include "viewer/remote_source.h"

#include <chrono>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "client/remote_jobs.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "core/shrm/shrm_file.h"

namespace shrm::viewer {

ShrmComputeFn RemoteCompute(const std::string& server, const std::string& env_path) {
  return [server, env_path](const ComputeRequest& req,
                            const PrefilterProgress& progress) -> absl::StatusOr<ShrmData> {
    const auto t0 = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client,
                          client::ShrmClient::Connect(server));
    absl::Status cancelled;
    client::RemotePrefilterOptions options;
    options.progress = [&](const shrm::v1::PrefilterProgress& p) {
      if (progress && cancelled.ok()) cancelled = progress(p.stage());
    };
    SHRM_ASSIGN_OR_RETURN(
        client::RemotePrefilterResult remote,
        client::RunRemotePrefilter(client.get(), server, PrefilterJobFor(req, env_path), options));
    SHRM_RETURN_IF_ERROR(cancelled);
    const client::PrefilterOutcome& out = remote.outcome;
    // ReadShrmFile reads paths: a private temporary file, removed afterwards.
    const std::string tmp = (std::filesystem::temp_directory_path() /
                             absl::StrCat("shrm-view-", out.shrm_sha256.substr(0, 16), ".shrm.exr"))
                                .string();
    SHRM_RETURN_IF_ERROR(WriteFileAtomically(tmp, out.shrm_file));
    absl::StatusOr<ShrmFile> file = ReadShrmFile(tmp);
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    if (!file.ok()) return file.status();
    if (progress) SHRM_RETURN_IF_ERROR(progress("convert"));
    SHRM_ASSIGN_OR_RETURN(
        ShrmData d, ShrmDataFromCube(std::move(file->cube), file->attributes,
                                     absl::StrCat("server ", server), std::max(1, req.threads)));
    d.compute_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return d;
  };
}

}  // namespace shrm::viewer
