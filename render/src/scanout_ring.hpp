// The bookkeeping of the scan-out ring (docs/rendering.md, "Scan-out"): which buffer object the
// warp may draw into next, given which one the display shows and which one a committed flip will
// show. After Weston's and kmscube's buffer release on the page-flip event: a buffer is free again
// once a newer one has replaced it on screen. With the KMS display's discipline (a flip is
// committed only after the flip before it completed) three buffers always leave one to draw into:
// one shown, one queued, one drawn. Pure, no GL: O(buffers) per call, no allocation after
// construction.
#pragma once

#include <cassert>
#include <vector>

namespace hmdnode::gpu {

class ScanoutRing {
  public:
    enum class State {
        free,     // nothing shows it or will: may be drawn into
        drawing,  // the warp draws into it now
        drawn,    // finished, not yet committed (the newest drawn one is what the display flips)
        queued,   // a flip to it was committed (shown at the flip's vsync, or already)
        shown,    // on screen until the next committed flip completes
    };

    explicit ScanoutRing(int buffers) : state_(size_t(buffers), State::free) {
        assert(buffers >= 1);
    }

    int size() const { return int(state_.size()); }
    State state(int b) const {
        assert(b >= 0 && b < size());
        return state_[size_t(b)];
    }

    // The next buffer to draw into: the first free one after the last acquired (round robin);
    // with none free, a drawn one that was never committed (it would be superseded anyway).
    // An abandoned draw (acquired, never finished) is free again. -1 when every buffer is shown
    // or queued.
    int acquire() {
        for (State& s : state_)
            if (s == State::drawing) s = State::free;
        const int n = size();
        int pick = -1;
        for (int k = 1; k <= n && pick < 0; ++k) {
            const int b = (last_ + k) % n;
            if (state_[size_t(b)] == State::free) pick = b;
        }
        for (int b = 0; b < n && pick < 0; ++b)
            if (state_[size_t(b)] == State::drawn) pick = b;
        if (pick < 0) return -1;
        state_[size_t(pick)] = State::drawing;
        last_ = pick;
        assert(consistent());
        return pick;
    }

    // The draw into b is complete: b is the newest drawn buffer; an older drawn one is free.
    void finish(int b) {
        assert(b >= 0 && b < size() && state_[size_t(b)] == State::drawing);
        for (State& s : state_)
            if (s == State::drawn) s = State::free;
        state_[size_t(b)] = State::drawn;
        assert(consistent());
    }

    // The newest drawn buffer, -1 when there is none (nothing drawn since the last commit).
    int drawn() const {
        for (int b = 0; b < size(); ++b)
            if (state_[size_t(b)] == State::drawn) return b;
        return -1;
    }

    // A flip to the drawn buffer b was committed. The display commits only after the flip before
    // completed, so the buffer queued before is now shown and the one shown before is free.
    void commit(int b) {
        assert(b >= 0 && b < size() && state_[size_t(b)] == State::drawn);
        for (State& s : state_) {
            if (s == State::shown)
                s = State::free;
            else if (s == State::queued)
                s = State::shown;
        }
        state_[size_t(b)] = State::queued;
        assert(consistent());
    }

  private:
    // The ring's invariant: at most one buffer drawing, one drawn, one queued and one shown
    // (the display shows one frame and holds one flip; the warp draws one).
    bool consistent() const {
        int count[5] = {};
        for (State s : state_) ++count[int(s)];
        return count[int(State::drawing)] <= 1 && count[int(State::drawn)] <= 1 &&
               count[int(State::queued)] <= 1 && count[int(State::shown)] <= 1;
    }

    std::vector<State> state_;
    int last_ = -1;
};

}  // namespace hmdnode::gpu
