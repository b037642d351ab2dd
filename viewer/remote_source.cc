#include "viewer/remote_source.h"

#include <chrono>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "client/shrm_client.h"
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
    shrm::v1::PrefilterRequest request;
    SHRM_ASSIGN_OR_RETURN(const std::string sha, client->UploadIfMissing(env_path));
    request.mutable_environment()->add_sha256(sha);
    request.mutable_environment()->add_source_names(env_path);
    SHRM_ASSIGN_OR_RETURN(client::RemoteBrdf brdf,
                          client::ResolveRemoteBrdf(req.brdf_spec, client.get()));
    request.set_brdf(brdf.spec);
    request.set_brdf_blob_sha256(brdf.blob_sha256);
    request.set_brdf_display_spec(brdf.display_spec);
    if (req.f >= 0) {
      request.mutable_orders()->set_f(req.f);
      request.mutable_orders()->set_p(req.p);
    } else {
      request.set_epsilon(req.epsilon);
    }
    request.set_kind(shrm::v1::SHRM_KIND_GLOBAL);
    request.set_face_size(req.face_size);
    absl::Status cancelled;
    auto on_progress = [&](const shrm::v1::PrefilterProgress& p) {
      if (progress && cancelled.ok()) cancelled = progress(p.stage());
    };
    SHRM_ASSIGN_OR_RETURN(client::PrefilterOutcome out, client->Prefilter(request, on_progress));
    SHRM_RETURN_IF_ERROR(cancelled);
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
