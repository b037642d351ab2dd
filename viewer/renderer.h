// The viewer's frame: background (the environment, lat-long lookup per pixel ray), the active
// render mode (viewer/render_mode.h) into an HDR framebuffer, the ground truth when it is needed
// (G-buffer pass -> viewer/progressive_reference.h on worker threads -> texture), then either the
// tone mapping (2^exposure, Reinhard x / (1 + x), sRGB; the operator of core's WritePreviewPng)
// or the difference view (relative error |mode - truth| / |truth| per pixel, false-coloured on a
// log scale from 1e-3 (blue) to 1 (red); grey where the truth is not computed yet), and progress
// bars (SHRM computation, ground truth) along the top edge.
#ifndef SHRM_VIEWER_RENDERER_H_
#define SHRM_VIEWER_RENDERER_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/image.h"
#include "viewer/camera.h"
#include "viewer/gl_util.h"
#include "viewer/gpu_mesh.h"
#include "viewer/overlay_gl.h"
#include "viewer/progressive_reference.h"
#include "viewer/render_mode.h"

namespace shrm::viewer {

struct RenderSettings {
  int mode = 1;       // registered key
  bool diff = false;  // difference view against the ground truth
  bool background = true;
  float exposure = 0;  // EV
  // Progress of an SHRM computation in [0, 1) (drawn as a bar), or < 0 for none.
  double compute_progress = -1;
  // The ground truth may (re)start for a new view: false while the camera moves.
  bool reference_may_restart = true;
  // In-frame text overlay (viewer/overlay_gl.h), one item per line, top-left; none if empty.
  std::vector<std::string> overlay;
  // World rotation R of the lighting (the live mode's turning map): the background shows the
  // rotated map, L(R^-1 d) along each pixel ray d (docs/envmap.md "Rotation").
  Mat3 background_rotation = Mat3::Identity();
};

// Statistics of the difference view once the ground truth of the view is complete.
struct DiffStats {
  bool valid = false;
  int64_t pixels = 0;
  double rel_rms = 0;     // sqrt(sum |a - b|^2 / sum |b|^2) over the covered pixels
  double rel_median = 0;  // median of |a - b| / |b|
  double rel_p99 = 0;
};

class Renderer {
 public:
  // GL context must be current (also when the renderer is destroyed: gl_util.h).
  // reference_threads: workers of the ground truth. Errors: the renderer's own programs and
  // framebuffers; a mode whose Init() fails is only unavailable (ModeError, InitErrors).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<Renderer>> Create(int width, int height,
                                                                        int reference_threads);

  [[nodiscard]] absl::Status Resize(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }

  void SetMesh(const Mesh& mesh);
  // New scene data: uploaded to every available mode, or only to mode `only_mode` (the live
  // mode's scene changes every frame: the other modes would recompute their tables for nothing;
  // SyncMode uploads it to a mode when it becomes active). The error names each mode that cannot
  // take it (the others go on; ModeError(key) keeps each mode's own).
  [[nodiscard]] absl::Status SetScene(const SceneData& scene,
                                      std::optional<int> only_mode = std::nullopt);
  // Uploads the current scene to `key`'s mode if a SetScene skipped it (its error, else OK).
  [[nodiscard]] absl::Status SyncMode(int key);
  const SceneData& scene() const { return scene_; }

  // Whether `key`'s mode is registered, available and has its inputs.
  bool ModeReady(int key) const;
  // Why `key`'s mode is unavailable or not ready: its Init() error, else its last Upload() or
  // Draw() error (each naming the mode); OK if none.
  absl::Status ModeError(int key) const;
  // The Init() errors of the unavailable modes, in one status (OK if every mode is available).
  absl::Status InitErrors() const;
  // Renders one frame into the LDR framebuffer (and the HDR one). Errors: unknown mode, no mesh,
  // or the mode's Draw() error (the mode is then not ready: render_mode.h).
  [[nodiscard]] absl::Status Render(const OrbitCamera& camera, const RenderSettings& settings);
  // Copies the LDR frame to the default framebuffer of the window (size w x h).
  void BlitToWindow(int window_width, int window_height) const;

  // Linear radiance of the last frame (RGBA, alpha 1 on the mesh), rows from the top.
  std::vector<float> ReadHdr() const;
  // The displayed frame as an RGB image with values in [0, 1], rows from the top.
  Image ReadLdr() const;
  // The ground truth of the current view (Wait() blocks until it is complete).
  ProgressiveReference& reference() { return *reference_; }
  bool reference_active() const { return reference_key_valid_; }
  const DiffStats& diff_stats() const { return diff_stats_; }
  std::string ModeStatus(int key) const;
  // Passes a key the viewer does not bind to mode `mode` (RenderMode::OnKey).
  bool ModeKey(int mode, int key, std::string* message);

 private:
  Renderer() = default;
  struct ModeSlot {
    const ModeInfo* info;
    std::unique_ptr<RenderMode> mode;
    absl::Status init_status;    // not OK: unavailable (never uploaded or drawn)
    absl::Status last_error;     // of the last Upload() or Draw()
    uint64_t scene_version = 0;  // the scene it has (SetScene's scene_version_)
  };
  absl::Status UploadTo(ModeSlot& slot);
  ModeSlot* Slot(int key);
  const ModeSlot* Slot(int key) const;
  RenderMode* Mode(int key) const;
  void DrawBackground(const OrbitCamera& camera, float aspect, const Mat3& rotation);
  void UpdateReference(const OrbitCamera& camera, const RenderSettings& settings);
  void ComputeDiffStats();

  int width_ = 0, height_ = 0;
  uint64_t mesh_version_ = 0, scene_version_ = 0;
  SceneData scene_;
  // GL objects, destroyed in reverse order of declaration (members after them first: the ground
  // truth's workers stop before anything else goes): the modes, the mesh, the framebuffers, the
  // overlay, the programs, the textures, the empty vertex array.
  GlVertexArray empty_vao_;
  GlTexture reference_texture_, env_texture_;
  GlProgram gbuffer_program_, diff_program_, tonemap_program_, background_program_;
  std::unique_ptr<OverlayGl> overlay_;
  std::unique_ptr<Framebuffer> gbuffer_, ldr_, hdr_;
  std::unique_ptr<GpuMesh> mesh_;
  std::vector<ModeSlot> modes_;
  std::unique_ptr<ProgressiveReference> reference_;
  std::string reference_key_;
  bool reference_key_valid_ = false;
  bool reference_current_ = false;  // the running truth is of this frame's view (not stale)
  bool reference_uploaded_complete_ = false;
  std::vector<float> reference_rgba_;  // GL order (row 0 at the bottom)
  DiffStats diff_stats_;
  int diff_stats_mode_ = -1;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_RENDERER_H_
