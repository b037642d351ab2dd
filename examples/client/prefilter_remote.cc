// A content tool's use of the shrm client library (shrm::client): one prefilter job on an shrmd
// service. The SHRM file it writes is byte-identical to `shrm prefilter`'s (embedded) output.
//   prefilter_remote SERVER MAP BRDF EPSILON OUTPUT
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#include "core/io/atomic_file.h"
#include "jobs/prefilter_job.h"
#include "shrm/version.h"

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s SERVER MAP BRDF EPSILON OUTPUT\n", argv[0]);
    return 2;
  }
  const std::string server = argv[1];
  shrm::jobs::PrefilterJob job;
  job.env.files = {argv[2]};
  job.brdf = argv[3];
  shrm::jobs::UseEpsilonRule(&job, std::strtod(argv[4], nullptr));
  if (absl::Status s = shrm::jobs::ValidatePrefilterJob(job); !s.ok()) {
    std::fprintf(stderr, "prefilter_remote: %s\n", std::string(s.message()).c_str());
    return 2;
  }

  absl::StatusOr<std::unique_ptr<shrm::client::ShrmClient>> client =
      shrm::client::ShrmClient::Connect(server);
  if (!client.ok()) {
    std::fprintf(stderr, "prefilter_remote: %s\n", std::string(client.status().message()).c_str());
    return 1;
  }
  absl::StatusOr<shrm::client::RemotePrefilterResult> result =
      shrm::client::RunRemotePrefilter(client->get(), server, job, {});
  if (!result.ok()) {
    std::fprintf(stderr, "prefilter_remote: %s\n", std::string(result.status().message()).c_str());
    return 1;
  }
  if (absl::Status s = shrm::WriteFileAtomically(argv[5], result->outcome.shrm_file); !s.ok()) {
    std::fprintf(stderr, "prefilter_remote: %s\n", std::string(s.message()).c_str());
    return 1;
  }
  std::printf("shrm %s client: %s from %s (F_B %d, P_B %d, %zu bytes, sha256 %s)\n", shrm::kVersion,
              argv[5], server.c_str(), result->outcome.report.f_b(), result->outcome.report.p_b(),
              result->outcome.shrm_file.size(), result->outcome.shrm_sha256.c_str());
  return 0;
}
