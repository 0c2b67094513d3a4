// Time left for a progress bar: the rate measured since the first progress report (so the
// loading, atlas and BVH time before it do not count as progress), extrapolated linearly to the
// end. No estimate (-1) until 3 % more of the work is done and half a second has passed since that
// first report: a rate from a few paths would say anything (hmdnode bake's first estimate was
// once 315,345 s). The bake's fraction counts every path it traces, lightmap texels and vertex
// queries alike (bake.cpp), so the estimate covers the whole tracing. Cost: O(1) per call.
#pragma once

namespace hmdnode {

class ProgressClock {
  public:
    // t: seconds on any steady clock; fraction in [0, 1]. Returns seconds left, or -1 when the
    // work done so far is too little to tell.
    double seconds_left(double t, double fraction) {
        if (fraction >= 1.0) return 0.0;
        if (!started_) {
            started_ = true;
            t0_ = t;
            f0_ = fraction;
            return -1.0;
        }
        const double df = fraction - f0_, dt = t - t0_;
        if (df < kMinFraction || dt < kMinSeconds) return -1.0;
        return (1.0 - fraction) * dt / df;
    }

    static constexpr double kMinFraction = 0.03;
    static constexpr double kMinSeconds = 0.5;

  private:
    bool started_ = false;
    double t0_ = 0.0, f0_ = 0.0;
};

}  // namespace hmdnode
