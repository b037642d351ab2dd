#include "jobs/job_options.h"

#include <array>

namespace shrm::jobs {
namespace {

constexpr unsigned kEverywhere = kCommandLine | kManifest | kWire;

// The files of a job: one map, or six faces (the manifest lists maps; a job takes one of them).
const std::array<JobOption, 16> kPrefilterOptions = {{
    {"env", "environment map file; give six files (+X -X +Y -Y +Z -Z) for a cube stored as faces",
     kCommandLine | kWire,
     "--env a.exr --env b.exr --env c.exr --env d.exr --env e.exr --env f.exr", "",
     [](PrefilterJob* j) { j->env.files = {"a.exr", "b.exr", "c.exr", "d.exr", "e.exr", "f.exr"}; },
     "manifest: \"maps\" lists single map files, one job each"},
    {"layout", "auto, latlong, cube, hcross, vcross, hstrip, vstrip, angular", kCommandLine | kWire,
     "--layout hcross", "", [](PrefilterJob* j) { j->env.layout = EnvLayout::kHorizontalCross; },
     "manifest: the layout is detected per map"},
    {"colour_space",
     "input colour space (default: lin_rec709 for float files, srgb_texture for 8/16-bit)",
     kCommandLine | kWire, "--colour-space acescg", "",
     [](PrefilterJob* j) { j->env.input_colour_space = "acescg"; },
     "manifest: maps are read in their files' colour spaces"},
    {"working_space", "linear working colour space", kCommandLine | kWire, "--working-space acescg",
     "", [](PrefilterJob* j) { j->env.working_colour_space = "acescg"; },
     "manifest: outputs are in lin_rec709"},
    {"ocio_config", "OpenColorIO config (default: $OCIO, then the built-in config)", kCommandLine,
     "--ocio-config my.ocio", "", [](PrefilterJob* j) { j->env.ocio_config = "my.ocio"; },
     "wire: a server reads no client files (refused with --server); manifest: as wire"},
    {"rotate", "rotate the lighting by yaw,pitch,roll degrees (exactly, in SH space)", kEverywhere,
     "--rotate 10,20,30", "[10, 20, 30]",
     [](PrefilterJob* j) {
       j->env.rotate_ypr_deg = std::array<double, 3>{10, 20, 30};
     },
     ""},
    {"replace_non_finite", "replace NaN/Inf pixels by 0 with a warning (default: reject the map)",
     kCommandLine | kWire, "--replace-non-finite", "",
     [](PrefilterJob* j) { j->env.replace_non_finite = true; },
     "manifest: a batch never changes pixels silently"},
    {"brdf", "BRDF spec, e.g. microfacet:sigma=0.2 (docs/brdf.md)", kCommandLine | kWire,
     "--brdf ggx:alpha=0.3", "", [](PrefilterJob* j) { j->brdf = "ggx:alpha=0.3"; },
     "manifest: \"brdfs\" lists the specs, one job each"},
    {"epsilon", "tolerance for the orders, in (0, 1)", kEverywhere, "--epsilon 0.05", "0.05",
     [](PrefilterJob* j) { j->epsilon = 0.05; }, ""},
    {"tolerance",
     "per-direction relative RMS tolerance, in (0, 1): orders, window and size chosen for the "
     "error "
     "seen per direction (docs/shrm.md); instead of --epsilon",
     kEverywhere, "--tolerance 0.02", "0.02", [](PrefilterJob* j) { j->tolerance = 0.02; }, ""},
    {"window", "ringing window on the lighting bands: none, lanczos, or auto (--tolerance chooses)",
     kEverywhere, "--window lanczos", "\"lanczos\"",
     [](PrefilterJob* j) { j->window = RingingWindow::kLanczos; }, ""},
    {"verify",
     "measure the result at N seeded (N, V) pairs against the brute-force sum (0: no check)",
     kEverywhere, "--verify 64", "64", [](PrefilterJob* j) { j->verify = 64; }, ""},
    {"orders", "explicit orders F,P instead of --epsilon", kEverywhere, "--orders 12,3", "\"12,3\"",
     [](PrefilterJob* j) {
       j->orders = Orders{12, 3};
     },
     ""},
    {"kind", "global or local SHRM", kEverywhere, "--kind local", "\"local\"",
     [](PrefilterJob* j) { j->kind = ShrmKind::kLocal; }, ""},
    {"size", "cube face size S_B (0: about 10 F_B)", kEverywhere, "--size 40", "40",
     [](PrefilterJob* j) { j->face_size = 40; }, ""},
    {"half", "store half floats instead of float32", kEverywhere, "--half", "true",
     [](PrefilterJob* j) { j->half = true; }, ""},
}};

}  // namespace

std::span<const JobOption> PrefilterJobOptions() { return kPrefilterOptions; }

const JobOption* FindPrefilterJobOption(std::string_view name) {
  for (const JobOption& o : kPrefilterOptions)
    if (o.name == name) return &o;
  return nullptr;
}

}  // namespace shrm::jobs
