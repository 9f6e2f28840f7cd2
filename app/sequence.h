#pragma once
// Frame sequences: which frames of an animation to render (`--frames A:B`, `--shard K/N`,
// `--resume`), where each one goes (`-o out/frame_####.png`), writing each image so that a
// killed job never leaves half a file under a final name, the progress line with an estimate
// of the time left, and the video made from the frames by ffmpeg (`--video`).
//
// Nothing here renders: the caller (tools/hfrt, an MPI rank) renders each planned frame with
// app::PreparedScene and hands the image to write_image_atomic().

#include <string>
#include <vector>

#include "base/result.h"
#include "base/timer.h"
#include "render/image.h"

namespace hfrt::app {

/// `-o` for a sequence: one run of '#' in the file name, replaced by the frame number padded
/// with zeros to the run's length (more digits when the number needs them).
struct FramePattern {
  std::string prefix, suffix;
  int width = 0;  ///< number of '#'; 0: not a pattern
};

/// Splits `path` at its run of '#'. False with `*err` when there are two runs or the run is in
/// a folder name (the frames of one sequence go to one folder). A path without '#' gives
/// width 0 (a single image).
bool parse_frame_pattern(const std::string& path, FramePattern* out, std::string* err);
/// The file of frame `frame`.
std::string frame_path(const FramePattern& pattern, int frame);
/// The printf-style pattern ffmpeg reads (`prefix%04dsuffix`, '%' in the name doubled).
std::string ffmpeg_pattern(const FramePattern& pattern);

/// `--frames A:B` or `--frames A` over an animation of `frames` frames (0-based, inclusive).
/// False with `*err` (naming the option and the valid range) when malformed or out of range.
bool parse_frame_range(const std::string& text, int frames, int* first, int* last,
                       std::string* err);
/// `--shard K/N`: 0 <= K < N. False with `*err` when malformed.
bool parse_shard(const std::string& text, int* k, int* n, std::string* err);

/// The frames of [first, last] that shard K of N renders (every N-th frame from the range's
/// K-th), less those already on disk when `resume` (their final file exists; a frame is
/// renamed into place only once complete). `*skipped` (may be null) gets the latter.
std::vector<int> plan_frames(int first, int last, int shard_k, int shard_n, bool resume,
                             const FramePattern& pattern, std::vector<int>* skipped);

/// Writes `image` (and its AOV siblings) to a temporary name in the folder of `path` and
/// renames it into place (AOVs first, the image last), so that `path` either does not exist or
/// is complete, whenever the process is killed. Returns the final paths written.
Result<std::vector<std::string>> write_image_atomic(const render::Image& image,
                                                    const std::string& path,
                                                    const render::AovSet& aovs = {});

/// Tracks a sequence's progress: `frame 12 (3/48) ... 6%, 3.1 s elapsed, about 46 s left`.
class SequenceProgress {
 public:
  explicit SequenceProgress(size_t total);
  /// Marks one more frame done; returns the line to print (no newline).
  std::string frame_done(int frame, const std::string& path, double frame_seconds);

 private:
  size_t total_, done_ = 0;
  Clock::time_point start_;
};

/// The path of an executable named `name` on PATH, or "" when there is none.
std::string find_on_path(const std::string& name);

/// Encodes the frames [first, last] of `pattern` into `video` with ffmpeg (H.264 in the
/// container the extension names, `fps` frames per second). Environment errors (no ffmpeg on
/// PATH, ffmpeg failing: its last output lines) come back as the result's error.
Result<bool> encode_video(const FramePattern& pattern, int first, int last, int fps,
                          const std::string& video);

}  // namespace hfrt::app
