// The `shrm` command. Subcommands:
//   analyze  SH lighting coefficients of an environment map and the orders needed for given
//            tolerances (SHRM paper eqs. 5.15-5.16). docs/cli.md documents every option.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/io/image.h"
#include "core/sh/sh.h"
#include "core/shrm/orders.h"
#include "core/transform/sht.h"

namespace shrm {
namespace {

// Default cap on the analysed degree: beyond it the demo's output stops being informative and
// the transform cost grows as F^2 H.
constexpr int kDefaultMaxDegree = 255;

struct AnalyzeOptions {
  std::string input = "data/envmaps/courtyard.exr";
  int lmax = -1;  // -1: what the map resolves, capped at kDefaultMaxDegree
  int print_lmax = 2;
  std::vector<double> epsilons = {0.2, 0.1, 0.05, 0.01};
  int threads = 0;  // 0: all hardware threads
  bool replace_non_finite = false;
};

absl::Status Analyze(AnalyzeOptions opt) {
  if (opt.lmax < -1) {
    return absl::InvalidArgumentError(absl::StrCat("--lmax must be >= 0, got ", opt.lmax));
  }
  if (opt.print_lmax < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--print-lmax must be >= 0, got ", opt.print_lmax));
  }
  if (opt.threads < 0) {
    return absl::InvalidArgumentError(absl::StrCat("--threads must be >= 0, got ", opt.threads));
  }
  for (double e : opt.epsilons) {
    if (!(e > 0 && e < 1)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--epsilon values must be in (0, 1), got ", e));
    }
  }
  const int threads =
      opt.threads > 0 ? opt.threads : std::max(1u, std::thread::hardware_concurrency());
  const auto t0 = std::chrono::steady_clock::now();
  auto image = ReadImageRgb(
      opt.input, {},
      opt.replace_non_finite ? NonFinitePolicy::kReplaceZero : NonFinitePolicy::kReject);
  if (!image.ok()) return image.status();
  if (image->width != 2 * image->height) {
    return absl::InvalidArgumentError(absl::StrCat(opt.input, ": a lat-long map must be 2:1, got ",
                                                   image->width, " x ", image->height));
  }
  const ShtGrid grid{image->width, image->height, ShtGridKind::kEquiangular};
  if (opt.lmax == -1) opt.lmax = std::min(ShtMaxDegree(grid), kDefaultMaxDegree);
  opt.print_lmax = std::min(opt.print_lmax, opt.lmax);
  if (opt.lmax > ShtMaxDegree(grid)) {
    return absl::InvalidArgumentError(absl::StrCat("--lmax ", opt.lmax, " is above what a ",
                                                   image->width, " x ", image->height,
                                                   " map resolves (", ShtMaxDegree(grid), ")"));
  }
  const auto t1 = std::chrono::steady_clock::now();
  auto coeffs = ForwardSht(grid, opt.lmax, 3, image->pixels, threads);
  if (!coeffs.ok()) return coeffs.status();
  const auto t2 = std::chrono::steady_clock::now();
  auto total = MapEnergy(grid, 3, image->pixels);
  if (!total.ok()) return total.status();
  const std::vector<double> bands = BandEnergies(opt.lmax, 3, *coeffs);
  auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };

  std::printf("map            %s (%d x %d lat-long, RGB)\n", opt.input.c_str(), image->width,
              image->height);
  if (image->replaced_non_finite > 0)
    std::printf("warning        %lld non-finite values replaced by 0\n",
                static_cast<long long>(image->replaced_non_finite));
  std::printf("transform      degree %d, %d thread(s): read %.1f ms, forward SHT %.1f ms\n\n",
              opt.lmax, threads, ms(t0, t1), ms(t1, t2));
  std::printf("SH lighting coefficients L_lm (real SH, SH frame: docs/conventions.md)\n");
  std::printf("  %3s %4s %14s %14s %14s\n", "l", "m", "R", "G", "B");
  for (int l = 0; l <= opt.print_lmax; ++l)
    for (int m = -l; m <= l; ++m) {
      const double* c = &(*coeffs)[static_cast<size_t>(ShIndex(l, m)) * 3];
      std::printf("  %3d %4d %14.6g %14.6g %14.6g\n", l, m, c[0], c[1], c[2]);
    }
  std::printf("\nEnergy (eq. 5.15): integral L^2 dw = %.6g %.6g %.6g (R G B)\n", (*total)[0],
              (*total)[1], (*total)[2]);
  std::printf("Captured fraction sum_{l<=F} |L_lm|^2 / integral L^2 (eq. 5.16)\n");
  std::printf("  %4s %10s %10s %10s\n", "F", "R", "G", "B");
  std::vector<int> rows;
  for (int f : {0, 1, 2, 3, 4, 6, 8, 10, 15, 20, 30, 40, 60, 80, 100, 150, 200, 300, 400, 500})
    if (f < opt.lmax) rows.push_back(f);
  rows.push_back(opt.lmax);
  for (int f : rows) {
    std::printf("  %4d", f);
    for (int c = 0; c < 3; ++c) {
      std::vector<double> band(opt.lmax + 1);
      for (int l = 0; l <= opt.lmax; ++l) band[l] = bands[static_cast<size_t>(l) * 3 + c];
      std::printf(" %10.6f", CapturedFraction(band, (*total)[c], f));
    }
    std::printf("\n");
  }
  std::printf(
      "\nOrder F_L for tolerance epsilon (smallest F capturing 1 - epsilon, max over RGB)\n");
  for (double e : opt.epsilons) {
    int worst = 0;
    for (int c = 0; c < 3 && worst >= 0; ++c) {
      std::vector<double> band(opt.lmax + 1);
      for (int l = 0; l <= opt.lmax; ++l) band[l] = bands[static_cast<size_t>(l) * 3 + c];
      const int f = OrderForTolerance(band, (*total)[c], e);
      worst = f < 0 ? -1 : std::max(worst, f);
    }
    if (worst >= 0) {
      std::printf("  epsilon %-8g F_L = %d\n", e, worst);
    } else {
      std::printf("  epsilon %-8g F_L > %d (raise --lmax)\n", e, opt.lmax);
    }
  }
  return absl::OkStatus();
}

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  CLI::App app{"shrm: frequency-space prefiltering of HDR environment maps"};
  app.require_subcommand(1);
  shrm::AnalyzeOptions analyze;
  CLI::App* a = app.add_subcommand(
      "analyze", "SH lighting coefficients and required orders of a lat-long HDR map");
  a->add_option("map", analyze.input, "lat-long environment map (EXR, HDR, PFM, TIFF, PNG)")
      ->capture_default_str();
  a->add_option("--lmax", analyze.lmax,
                "maximum SH degree of the transform (default: what the map resolves, at most 255)")
      ->capture_default_str();
  a->add_option("--print-lmax", analyze.print_lmax, "print coefficients up to this degree")
      ->capture_default_str();
  a->add_option("--epsilon", analyze.epsilons, "tolerances for the order analysis (0 < e < 1)")
      ->capture_default_str();
  a->add_option("--threads", analyze.threads, "worker threads (0: all cores)")
      ->capture_default_str();
  a->add_flag("--replace-non-finite", analyze.replace_non_finite,
              "replace NaN/Inf pixels by 0 (with a warning) instead of rejecting the map");
  CLI11_PARSE(app, argc, argv);
  absl::Status status = shrm::Analyze(analyze);
  if (!status.ok()) {
    std::fprintf(stderr, "shrm: error: %s\n", std::string(status.message()).c_str());
    return 1;
  }
  return 0;
}
