// Dithered LOD cross-fade (screen-door transparency, after the "alpha-to-coverage-free" LOD fades
// of game engines, e.g. Unity's LOD cross-fade and Unreal's dithered LOD transition): both levels
// are drawn with complementary ordered-dither masks for a few frames, so a level change never shows
// as a one-frame jump. Cost: O(1) per object per frame here; on the GPU each transition draws the
// two levels' triangles for fade_frames frames (docs/lod-selection.md, "No pops").
#include "hmdnode/lod/cross_fade.hpp"

#include <algorithm>
#include <cmath>

namespace hmdnode {

LodCrossFade::LodCrossFade(size_t object_count, int fade_frames)
    : frames_(std::clamp(fade_frames, 0, kMaxLodFadeFrames)),
      shown_(object_count, -1),
      from_(object_count, -1),
      step_(object_count, 0) {}

int LodCrossFade::dither_of_step(int s) const {
    const int k = int(std::lround(16.0 * double(s) / double(frames_ + 1)));
    return std::clamp(k, 1, 15);
}

void LodCrossFade::hide(size_t i) {
    shown_[i] = -1;
    step_[i] = 0;
}

LodFadeStep LodCrossFade::update(size_t i, int wanted) {
    LodFadeStep out;
    int& shown = shown_[i];
    int& step = step_[i];
    if (step > 0 && ++step > frames_) step = 0;  // the transition's last frame has been shown
    if (shown < 0) {
        shown = wanted;  // came into view
    } else if (step == 0 && wanted != shown) {
        if (frames_ > 0) {
            from_[i] = shown;
            step = 1;
            out.started = true;
        } else {
            out.popped = true;
        }
        shown = wanted;
    }
    out.draws[0] = LodFadeDraw{shown, 0};
    if (step > 0) {
        const int k = dither_of_step(step);
        out.draws[0].dither = k;
        out.draws[1] = LodFadeDraw{from_[i], -k};
        out.count = 2;
    }
    return out;
}

}  // namespace hmdnode
