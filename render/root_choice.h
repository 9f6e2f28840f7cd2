#pragma once
// The root-search choice of `--root auto` (the renderer's policy, shared by `hfrt render`,
// the REPL and every embedder): the analytic search when the field lists ray candidates
// (for many polynomial leaves, only when a probe shows the interval search's enclosures too
// loose); else the interval search with tile culling, unless the field has no intervals or a
// small probe render shows that its enclosures are too loose for intervals to pay, and then
// the sign-change march without culling. The probe counts evaluations, it does not time them, so
// the choice does not depend on the machine or its load.

#include <string>

#include "render/field.h"
#include "render/renderer.h"

namespace hfrt::render {

/// What the caller knows of the model's analytic (polynomial) structure, as text for the user.
struct AnalyticRootInfo {
  /// Why the analytic search applies ("analytic: 3 polynomial leaves of degree <= 4"); used
  /// when the field lists ray candidates. Empty: a generic text.
  std::string description;
  /// When it does not qualify: the first construct that is not polynomial, with its location
  /// ("'sin' is not a polynomial at model.hf:3:9"); empty when it qualifies or is unknown.
  std::string not_qualified;
  /// The polynomial leaves the analytic search solves on every ray, and its mesh and patch
  /// leaves (0 when unknown): from kAutoProbeAnalyticLeaves polynomial leaves and without
  /// mesh or patch leaves, `auto` probes the interval search first.
  int num_leaves = 0;
  int num_surface_leaves = 0;
};

/// From this many polynomial leaves `--root auto` does not take the analytic search without a
/// probe: every ray solves every leaf, and a union of spheres rendered faster by the interval
/// search at every size measured (512x512, 2 cores, analytic / interval: 16 spheres
/// 0.075-0.081 / 0.052-0.068 s, 32 0.217-0.221 / 0.126-0.136 s, 72 0.736-0.793 / 0.434-0.493
/// s; 8 spheres 0.039 / 0.029 s, below the threshold, where the scenes with few leaves that
/// the analytic search serves far better, quartic tori and R-function CSG of quadrics, live).
inline constexpr int kAutoProbeAnalyticLeaves = 16;

/// The `--root auto` decision, for the user and --stats.
struct RootDecision {
  std::string why;      ///< empty unless opt->root was kAuto
  bool probed = false;  ///< a probe render was made
  double probe_ms = 0;
  /// When `auto` could not take the analytic search: AnalyticRootInfo::not_qualified.
  std::string analytic_fallback;
};

/// Settles RootMode::kAuto in `opt` (root, and tile_culling when the march is chosen); no-op
/// for the other modes. The probe renders at most 24 pixels on the larger side, with
/// opt's camera, box and threads and no shadows.
RootDecision choose_root(const Field& field, RenderOptions* opt, const AnalyticRootInfo& analytic);

}  // namespace hfrt::render
