#include "jobs/job_options.h"

#include <algorithm>
#include <array>

namespace shrm::jobs {
namespace {

constexpr unsigned kEverywhere = kCommandLine | kManifest | kWire;

// The environment options, which every job kind with a map has (the files of a job: one map, or
// six faces; the manifest lists maps, a job takes one of them).
template <typename Job>
std::array<JobOptionOf<Job>, 7> EnvironmentOptions() {
  using J = Job;
  return {{
      {"env", "environment map file; give six files (+X -X +Y -Y +Z -Z) for a cube stored as faces",
       kCommandLine | kWire,
       "--env a.exr --env b.exr --env c.exr --env d.exr --env e.exr --env f.exr", "",
       [](J* j) { j->env.files = {"a.exr", "b.exr", "c.exr", "d.exr", "e.exr", "f.exr"}; },
       "manifest: \"maps\" lists single map files, one job each"},
      {"layout", "auto, latlong, cube, hcross, vcross, hstrip, vstrip, angular",
       kCommandLine | kWire, "--layout hcross", "",
       [](J* j) { j->env.layout = EnvLayout::kHorizontalCross; },
       "manifest: the layout is detected per map"},
      {"colour_space",
       "input colour space (default: lin_rec709 for float files, srgb_texture for 8/16-bit)",
       kCommandLine | kWire, "--colour-space acescg", "",
       [](J* j) { j->env.input_colour_space = "acescg"; },
       "manifest: maps are read in their files' colour spaces"},
      {"working_space", "linear working colour space", kCommandLine | kWire,
       "--working-space acescg", "", [](J* j) { j->env.working_colour_space = "acescg"; },
       "manifest: outputs are in lin_rec709"},
      {"ocio_config", "OpenColorIO config (default: $OCIO, then the built-in config)", kCommandLine,
       "--ocio-config my.ocio", "", [](J* j) { j->env.ocio_config = "my.ocio"; },
       "wire: a server reads no client files (refused with --server); manifest: as wire"},
      {"rotate", "rotate the lighting by yaw,pitch,roll degrees (exactly, in SH space)",
       kEverywhere, "--rotate 10,20,30", "[10, 20, 30]",
       [](J* j) {
         j->env.rotate_ypr_deg = std::array<double, 3>{10, 20, 30};
       },
       ""},
      {"replace_non_finite", "replace NaN/Inf pixels by 0 with a warning (default: reject the map)",
       kCommandLine | kWire, "--replace-non-finite", "",
       [](J* j) { j->env.replace_non_finite = true; },
       "manifest: a batch never changes pixels silently"},
  }};
}

template <typename Job, size_t N, size_t M>
std::array<JobOptionOf<Job>, N + M> Concat(const std::array<JobOptionOf<Job>, N>& a,
                                           const std::array<JobOptionOf<Job>, M>& b) {
  std::array<JobOptionOf<Job>, N + M> out;
  std::copy(a.begin(), a.end(), out.begin());
  std::copy(b.begin(), b.end(), out.begin() + N);
  return out;
}

template <typename Option, size_t N>
const Option* FindOption(const std::array<Option, N>& table, std::string_view name) {
  for (const Option& o : table)
    if (o.name == name) return &o;
  return nullptr;
}

// The prefilter job's own options (after the environment's).
const std::array<JobOption, 12> kPrefilterJobOptions = {{
    {"brdf", "BRDF spec, e.g. microfacet:sigma=0.2 (docs/brdf.md)", kCommandLine | kWire,
     "--brdf ggx:alpha=0.3", "", [](PrefilterJob* j) { j->brdf = "ggx:alpha=0.3"; },
     "manifest: \"brdfs\" lists the specs, one job each"},
    {"epsilon",
     "the paper's energy tolerance for the orders, in (0, 1) (sec. 5.5; 0.03 in the paper), "
     "instead of --tolerance",
     kEverywhere, "--epsilon 0.05", "0.05", [](PrefilterJob* j) { UseEpsilonRule(j, 0.05); }, ""},
    {"tolerance",
     "per-direction relative RMS tolerance, in (0, 1) (default 0.01): orders, window and size "
     "chosen for the error seen per direction (docs/shrm.md)",
     kEverywhere, "--tolerance 0.02", "0.02", [](PrefilterJob* j) { UseToleranceRule(j, 0.02); },
     ""},
    {"window", "ringing window on the lighting bands: none, lanczos, or auto (--tolerance chooses)",
     kEverywhere, "--window lanczos", "\"lanczos\"",
     [](PrefilterJob* j) { j->window = RingingWindow::kLanczos; }, ""},
    {"view_variable",
     "variable of the view expansion: normal (N = (R + V)/|R + V|: converges at grazing views), "
     "view (the paper's V), or auto (--tolerance chooses, normal first; view with --epsilon or "
     "--orders)",
     kEverywhere, "--view-variable normal", "\"normal\"",
     [](PrefilterJob* j) { j->view = ViewVariable::kNormal; }, ""},
    {"verify",
     "measure the result at N seeded (N, V) pairs against the brute-force sum (default 64; 0: "
     "no check)",
     kEverywhere, "--verify 16", "16", [](PrefilterJob* j) { j->verify = 16; }, ""},
    {"orders", "explicit orders F,P instead of --tolerance", kEverywhere, "--orders 12,3",
     "\"12,3\"",
     [](PrefilterJob* j) {
       UseExplicitOrders(j, Orders{12, 3});
     },
     ""},
    {"kind", "global or local SHRM", kEverywhere, "--kind local", "\"local\"",
     [](PrefilterJob* j) { j->kind = ShrmKind::kLocal; }, ""},
    {"size",
     "cube face size S_B (0: about 10 F_B; with --tolerance chosen by its interpolation estimate)",
     kEverywhere, "--size 40", "40", [](PrefilterJob* j) { j->face_size = 40; }, ""},
    {"half", "store half floats instead of float32", kEverywhere, "--half", "true",
     [](PrefilterJob* j) { j->half = true; }, ""},
    {"max_size",
     "size budget of the SHRM file in MB with the tolerance rule (0: none): the most accurate "
     "choice "
     "within it, reported, when the tolerance needs more",
     kEverywhere, "--max-size 32", "32", [](PrefilterJob* j) { j->max_size_mb = 32; }, ""},
    {"peak_lights",
     "auto|on|off: ship the map's brightest pixels as directional lights beside the SHRM, summed "
     "exactly wherever it is evaluated (shrm eval and render, shrm-view, the shipped shaders "
     "through --ktx2); the expansion holds the rest. on: wherever a split pays (a sun, lamps, a "
     "bright sky); auto: the same, with the tolerance rule and a view-dependent analytic BRDF "
     "(docs/shrm.md \"Peak lights\")",
     kEverywhere, "--peak-lights off", "\"off\"",
     [](PrefilterJob* j) { j->peak_lights = PeakLights::kOff; }, ""},
}};
const std::array<JobOption, 19> kPrefilterOptions =
    Concat(EnvironmentOptions<PrefilterJob>(), kPrefilterJobOptions);

// The IBL job's own options (after the environment's).
const std::array<IblJobOption, 14> kIblJobOptions = {{
    {"preset",
     "roughness per mip: filament (cmgen), gltf (glTF-IBL-Sampler), babylon (Babylon.js's "
     "glTF loader) or explicit",
     kEverywhere, "--preset gltf", "\"gltf\"",
     [](IblJob* j) { j->preset = ibl::RoughnessPreset::kGltf; }, ""},
    {"roughness", "explicit perceptual roughness per level, r0,r1,... (implies --preset explicit)",
     kEverywhere, "--roughness 0,0.5,1", "[0, 0.5, 1]",
     [](IblJob* j) {
       j->preset = ibl::RoughnessPreset::kExplicit;
       j->roughness = {0, 0.5, 1};
     },
     ""},
    {"size", "base face size (a power of two)", kEverywhere, "--size 128", "128",
     [](IblJob* j) { j->face_size = 128; }, ""},
    {"levels", "mip levels (0: the preset's default)", kEverywhere, "--levels 5", "5",
     [](IblJob* j) { j->levels = 5; }, ""},
    {"sheen", "also the Charlie sheen chain", kEverywhere, "--sheen", "true",
     [](IblJob* j) { j->sheen = true; }, ""},
    {"format", "radiance storage: rgba16f, rgba32f, r11g11b10f or rgb9e5", kEverywhere,
     "--format rgb9e5", "\"rgb9e5\"", [](IblJob* j) { j->format = IblFormat::kE5b9g9r9; }, ""},
    {"irradiance_size", "irradiance cube face size", kEverywhere, "--irradiance-size 16", "16",
     [](IblJob* j) { j->irradiance_size = 16; }, ""},
    {"dfg_size", "DFG lookup table size", kEverywhere, "--dfg-size 64", "64",
     [](IblJob* j) { j->dfg_size = 64; }, ""},
    {"tolerance", "relative RMS per direction allowed on every level (largest: 5x)", kEverywhere,
     "--tolerance 0.002", "0.002", [](IblJob* j) { j->tolerance = 0.002; }, ""},
    {"verify", "directions per level checked against the brute-force sum (0: none)", kEverywhere,
     "--verify 0", "0", [](IblJob* j) { j->verify = 0; }, ""},
    {"sh_window",
     "SH9 ringing control: auto (weakest window keeping the irradiance >= 0), none, cmgen "
     "(cmgen's --sh-window=auto)",
     kEverywhere, "--sh-window cmgen", "\"cmgen\"",
     [](IblJob* j) { j->sh_window = IblShWindow::kCmgen; }, ""},
    {"dfg",
     "DFG table for: auto (the preset's engine), none, filament, filament-cmgen-exact, "
     "filament-single-scatter, gltf-lut-ggx, gltf-lut-charlie, gltf-lut-sheen-e, babylon, karis",
     kEverywhere, "--dfg babylon", "\"babylon\"", [](IblJob* j) { j->dfg = "babylon"; }, ""},
    {"containers",
     "files to write, a list of: ktx2 (KTX2 cubes and DFG), ktx1 (Filament: cmgen's ibl.ktx, "
     "skybox.ktx, sh.txt), gltf (ibl.glb with EXT_lights_image_based), or all",
     kEverywhere, "--containers ktx2,ktx1", "\"ktx2,ktx1\"",
     [](IblJob* j) {
       j->containers = {IblContainer::kKtx2, IblContainer::kKtx1};
     },
     ""},
    {"preview",
     "also preview.png: a contact sheet, one row per level (the six faces and a mirror sphere)",
     kEverywhere, "--preview", "true", [](IblJob* j) { j->preview = true; }, ""},
}};
const std::array<IblJobOption, 21> kIblOptions =
    Concat(EnvironmentOptions<IblJob>(), kIblJobOptions);

}  // namespace

std::span<const JobOption> PrefilterJobOptions() { return kPrefilterOptions; }

const JobOption* FindPrefilterJobOption(std::string_view name) {
  return FindOption(kPrefilterOptions, name);
}

std::span<const IblJobOption> IblJobOptions() { return kIblOptions; }

const IblJobOption* FindIblJobOption(std::string_view name) {
  return FindOption(kIblOptions, name);
}

}  // namespace shrm::jobs
