// The viewer's render modes: one class per mode, each in its own viewer/mode_<name>.{h,cc},
// registered by ONE line in the table of viewer/mode_registry.cc. The renderer owns the window,
// the mesh, the environment background, the ground truth and the post passes (tone mapping,
// difference view); a mode only turns the scene into linear radiance on the mesh.
//
// Adding a mode (e.g. 3, "low-frequency SH lighting with per-pixel BRDF coefficients"):
//   1. viewer/mode_sh_lighting.h / .cc: `class ShLightingMode final : public RenderMode` and a
//      factory `std::unique_ptr<RenderMode> MakeShLightingMode();`;
//   2. one line in kModes (viewer/mode_registry.cc):
//        {3, "sh-lighting", "low-frequency SH lighting, per-pixel BRDF coefficients",
//         MakeShLightingMode},
//   viewer/CMakeLists.txt picks up every viewer/mode_*.cc by itself. The key (1-9) is also the
//   `--mode N` number; keys without a registered mode print "mode N is not available".
//
// Life cycle (all calls on the GL thread, with the context current; a mode is destroyed while the
// context is still current, so GL objects live in the handles of viewer/gl_util.h):
//   Init() once after creation; Upload(scene) whenever the scene data changes (a new SHRM swapped
//   in after an asynchronous recompute, a new environment or BRDF; fields may be null: a mode
//   whose inputs are missing returns false from ready() and is not drawn); Draw(frame) per frame,
//   only while ready().
// Errors are values, and a mode never prints them (the program reports them, viewer/app.cc):
//  - Init(): the mode is unavailable (e.g. a program that does not link: GL 3.3 guarantees only
//    64 vertex output components); the renderer keeps the status and goes on without the mode;
//  - Upload(): what the mode cannot take (a cube beyond the GL limits, a BRDF its tables refuse);
//    it is then not ready() until an Upload() succeeds;
//  - Draw(): what failed on first use (a shader variant, a table computed lazily); the mode is
//    then not ready() until what it draws changes (OnKey, new settings, Upload), so a frame loop
//    reports it once.
//
// What Draw() gets and must do (and return OK, or the error above):
//  - the HDR framebuffer is bound (colour GL_RGBA32F, depth 24 bit, depth test GL_LESS enabled,
//    viewport = frame.width x frame.height); the background is already drawn (alpha 0);
//  - draw frame.mesh (GpuMesh::Draw; attributes documented in viewer/gpu_mesh.h) with your
//    program and write LINEAR RADIANCE (working-space RGB of the environment) with alpha = 1;
//    exposure and tone mapping are applied afterwards by the renderer (frame.exposure is given
//    for modes that need it, e.g. for dithering, and is otherwise ignored);
//  - shared GLSL pieces: viewer/glsl_snippets.h (mesh vertex shader) and the shipped shader
//    library shaders/glsl/ ("shrm/shaders.h": real SH evaluation with the
//    Condon-Shortley phase in the SH frame of docs/conventions.md, cube-face addressing).
// Scene data for low-frequency modes: scene.env->sh holds the RGB lighting coefficients L_lm to
// degree scene.env->sh_lmax (core/envmap/lighting.h layout, SH frame), scene.env->latlong the map;
// scene.brdf / scene.brdf_spec the BRDF (compute your own coefficients from it in Upload()).
#ifndef SHRM_VIEWER_RENDER_MODE_H_
#define SHRM_VIEWER_RENDER_MODE_H_

#include <epoxy/gl.h>

#include <memory>
#include <span>
#include <string>

#include "absl/status/status.h"
#include "core/brdf/brdf.h"
#include "core/ibl/split_sum.h"
#include "viewer/camera.h"
#include "viewer/gpu_mesh.h"
#include "viewer/scene_source.h"

namespace shrm::viewer {

// Data that changes rarely (Upload()). Any pointer may be null.
struct SceneData {
  std::shared_ptr<const ShrmData> shrm;        // global + local SHRM cubes, orders, attributes
  std::shared_ptr<const EnvironmentData> env;  // map, lat-long copy, SH lighting, reference
  std::shared_ptr<const Brdf> brdf;            // the BRDF of shrm (or of --brdf)
  std::string brdf_spec;
  // --live: the session's split-sum set of the shown lighting (mode 6 shades with its chain
  // instead of computing one from env; viewer/live_source.h).
  std::shared_ptr<const ibl::SplitSumSet> split_sum;
};

// Per-frame inputs (Draw()).
struct FrameInputs {
  const GpuMesh* mesh = nullptr;
  const OrbitCamera* camera = nullptr;
  Mat4f view{}, projection{}, view_projection{};  // column-major
  Vec3 eye;                                       // world position of the camera
  Vec3 central_view;  // unit, target -> eye (the V of a per-view reflection map)
  int width = 0, height = 0;
  float exposure = 0;      // EV
  GLuint env_texture = 0;  // lat-long background, GL_TEXTURE_2D RGB32F, 0 without --env
  // Ground truth of this view (viewer/progressive_reference.h), GL_TEXTURE_2D RGBA32F of
  // width x height, row 0 at the BOTTOM (GL order); alpha 1 computed, 0.5 estimate, 0 none.
  // 0 when no ground truth is running.
  GLuint reference_texture = 0;
  double reference_progress = 0;
};

class RenderMode {
 public:
  virtual ~RenderMode() = default;
  [[nodiscard]] virtual absl::Status Init() = 0;
  [[nodiscard]] virtual absl::Status Upload(const SceneData& scene) = 0;
  virtual bool ready() const = 0;
  [[nodiscard]] virtual absl::Status Draw(const FrameInputs& frame) = 0;
  // One line for the overlay (orders, sizes, per-frame CPU work), "" if nothing to say.
  virtual std::string Status() const { return ""; }
  // This mode shows the ground truth: the renderer keeps it computing while the mode is active.
  virtual bool needs_reference() const { return false; }
  // A key the viewer does not bind itself, while this mode is active (GLFW key code: letters are
  // their upper-case ASCII). Returns true if the mode used it, with a line for stdout in *message.
  virtual bool OnKey(int /*key*/, std::string* /*message*/) { return false; }
};

struct ModeInfo {
  int key;                  // 1-9: the key and the --mode number
  const char* name;         // short name, e.g. "global-shrm"
  const char* description;  // one line for --help, the overlay and docs/viewer.md
  std::unique_ptr<RenderMode> (*create)();
};

// The registered modes, in key order (viewer/mode_registry.cc).
std::span<const ModeInfo> RegisteredModes();
// The mode of `key`, or nullptr.
const ModeInfo* FindMode(int key);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_RENDER_MODE_H_
