// `shrm brdf-table` (docs/cli.md): samples a BRDF model into the tabulated form that
// `--brdf table:PATH` reads (core/brdf/brdf_table.h): the same grid a measured BRDF is resampled
// to, so a table run can be compared with its analytic model, and a model shipped as data.
//
// Exit codes: malformed options are usage errors (2); a BRDF spec the parser refuses, sizes out
// of range and an unwritable output are input errors (1), each checked before any work. The
// file is written atomically (temporary + rename): a failed run leaves nothing.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_table.h"
#include "core/io/atomic_file.h"

namespace shrm::cli {
namespace {

struct BrdfTableArgs {
  std::string brdf;
  std::vector<int> size = {128, 64, 64};  // n_theta_i, n_theta_o, n_phi
  std::string output;
};

absl::Status RunBrdfTable(const BrdfTableArgs& a) {
  if (absl::StartsWith(a.brdf, "table:") || absl::StartsWith(a.brdf, "merl:")) {
    return absl::InvalidArgumentError(
        absl::StrCat("--brdf ", a.brdf, ": samples an analytic model (a table is one already)"));
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(a.brdf));
  const std::filesystem::path folder = std::filesystem::path(a.output).parent_path();
  std::error_code ec;
  if (!folder.empty() && !std::filesystem::is_directory(folder, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--output ", a.output, ": the folder ", folder.string(), " does not exist"));
  }
  if (a.size.size() != 3) {
    return absl::InvalidArgumentError("--size takes three numbers: n_theta_i,n_theta_o,n_phi");
  }
  for (const int n : a.size) {
    if (n < 1 || n > kMaxBrdfTableDim) {
      return absl::InvalidArgumentError(absl::StrCat("--size ", a.size[0], ",", a.size[1], ",",
                                                     a.size[2], ": each must be in [1, ",
                                                     kMaxBrdfTableDim, "]"));
    }
  }
  const double bytes = 8.0 * a.size[0] * a.size[1] * a.size[2] * brdf->channels();
  constexpr double kMaxTableBytes = 4.0 * (1 << 30);
  if (bytes > kMaxTableBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("--size: the table would take ", bytes / (1 << 20), " MiB (at most 4 GiB)"));
  }
  SHRM_ASSIGN_OR_RETURN(BrdfTableData table,
                        SampleBrdfTable(*brdf, a.size[0], a.size[1], a.size[2]));
  // Temporary + rename (core/io/atomic_file.h): a failed write leaves nothing behind.
  const std::string tmp = TempPathFor(a.output);
  if (absl::Status s = WriteBrdfTable(tmp, table); !s.ok()) {
    DiscardTempFile(tmp);
    return absl::InvalidArgumentError(
        absl::StrCat("--output ", a.output, ": cannot write the table (", s.message(), ")"));
  }
  SHRM_RETURN_IF_ERROR(CommitTempFile(tmp, a.output));
  std::printf(
      "wrote %s: %s sampled on %d x %d x %d cells x %d channel(s), %.1f MB; use --brdf "
      "table:%s\n",
      a.output.c_str(), brdf->spec().c_str(), a.size[0], a.size[1], a.size[2], table.channels,
      bytes / 1e6, a.output.c_str());
  return absl::OkStatus();
}

}  // namespace

void DefineBrdfTable(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<BrdfTableArgs>();
  sub->add_option("--brdf", args->brdf, "analytic BRDF spec to sample (e.g. ggx:alpha=0.3,f0=1)")
      ->required();
  sub->add_option("--size", args->size,
                  "cells in theta_i', theta_o' and phi of the reparameterized grid")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  sub->add_option("-o,--output", args->output, "output table file (read by --brdf table:PATH)")
      ->required();
  sub->callback([args, status] { *status = RunBrdfTable(*args); });
}

}  // namespace shrm::cli
