#include "jobs/ibl_outputs.h"

namespace shrm::jobs {

absl::StatusOr<std::vector<IblFile>> EncodeIblOutputs(const IblJob& job, const IblRun& run) {
  std::vector<IblFile> files;
  nlohmann::json sidecar = run.report;
  nlohmann::json list = nlohmann::json::array();
  for (const IblFile& f : files) list.push_back({{"name", f.name}, {"what", f.what}});
  sidecar["files"] = list;
  files.push_back({"ibl.json", sidecar.dump(2) + "\n", "the set's description and report"});
  return files;
}

}  // namespace shrm::jobs
