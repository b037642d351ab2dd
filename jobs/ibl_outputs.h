// The files of the IBL job (jobs/ibl_job.h), encoded in memory so that every front end writes the
// same bytes (docs/ibl.md "Files"): the radiance chains, the irradiance cube and the DFG table as
// KTX2 (core/export/ktx2.h), the SH coefficients in each engine's convention, and the JSON
// sidecar that describes them all (orientation, units, conventions, the report).
#ifndef SHRM_JOBS_IBL_OUTPUTS_H_
#define SHRM_JOBS_IBL_OUTPUTS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "jobs/ibl_job.h"

namespace shrm::jobs {

// preview.png's layout: tiles of kPreviewTile x kPreviewTile pixels with kPreviewGap between
// them and at the borders; 7 tiles a row (six faces, a sphere), one row per specular level and
// one for the irradiance.
inline constexpr int kPreviewTile = 64;
inline constexpr int kPreviewGap = 4;

struct IblFile {
  std::string name;   // file name inside the output folder
  std::string bytes;  // contents
  std::string what;   // one line for the summary
  // "cube" (a KTX2 cube map, one level per roughness), "table" (the 2D DFG table: KTX2, EXR,
  // PNG), "ktx1" (Filament's KTX1 cubes), "gltf" (ibl.glb), "text" (sh.txt), "image"
  // (preview.png), "json".
  std::string type;
};

// The job's files, the sidecar "ibl.json" last (it lists the others).
absl::StatusOr<std::vector<IblFile>> EncodeIblOutputs(const IblJob& job, const IblRun& run);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_IBL_OUTPUTS_H_
