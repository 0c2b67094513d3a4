// Pop-free level changes: a dithered cross-fade (screen-door transparency) between an object's old
// and new LOD level over a few frames, and the count of level changes shown without one ("pops").
// docs/lod-selection.md, "No pops", has the definition, the choice against geomorphing and the
// cost.
//
// Threads: one LodCrossFade belongs to the frame thread. update() neither allocates nor locks.
#pragma once

#include <cstddef>
#include <vector>

namespace hmdnode {

// The largest fade: the screen-door tile has 16 ranks (DrawItem::dither, render/renderer.hpp), so
// at most 15 intermediate steps differ.
inline constexpr int kMaxLodFadeFrames = 15;

// One draw of an object: a level and the DrawItem::dither its pixels are masked with (0: all).
struct LodFadeDraw {
    int level = 0;
    int dither = 0;
};

// What one new frame draws of one visible object.
struct LodFadeStep {
    LodFadeDraw draws[2];  // draws[0]: the level shown (fading in), draws[1]: the one fading out
    int count = 1;         // 2 during a transition
    bool started = false;  // a transition began with this frame
    bool popped = false;   // the level changed in one frame (transitions off): a pop
};

class LodCrossFade {
  public:
    // fade_frames: new frames a transition draws both levels (0: off, every change pops; clamped
    // to kMaxLodFadeFrames).
    LodCrossFade(size_t object_count, int fade_frames);

    // Object `i` is drawn in this new frame and the LOD policy wants `wanted`. A visible object
    // whose shown level differs starts a transition: for frames s = 1..N (N = fade_frames) the new
    // level is drawn with dither +k_s and the old one with -k_s, k_s = round(16 s / (N + 1)) in
    // 1..15, so the new level's share of the pixels grows 1/(N+1), 2/(N+1), ... and every pixel
    // shows exactly one of them; frame N + 1 draws the new level alone. A level wanted while a
    // transition runs waits for its end (at most N frames). An object that was not drawn in the
    // previous new frame takes its level at once: nothing was on screen to pop.
    LodFadeStep update(size_t i, int wanted);
    // Object `i` is not drawn in this new frame (culled): it has no level on screen.
    void hide(size_t i);

    int fade_frames() const { return frames_; }
    // The dither of the new level in step s (1..fade_frames) of a transition.
    int dither_of_step(int s) const;

  private:
    int frames_ = 0;
    std::vector<int> shown_;  // level on screen (the new one during a transition); -1: not shown
    std::vector<int> from_;   // the level fading out
    std::vector<int> step_;   // 1..frames_ during a transition, 0 otherwise
};

}  // namespace hmdnode
