// PSNR and SSIM of 8-bit images.
//
// SSIM: Z. Wang, A. C. Bovik, H. R. Sheikh, E. P. Simoncelli, "Image quality assessment: from error
// visibility to structural similarity", IEEE Trans. Image Processing 13(4), 2004, with the
// parameters of its reference implementation (ssim_index.m): a normalised 11x11 circular-symmetric
// Gaussian window of sigma 1.5, C1 = (0.01 L)^2, C2 = (0.03 L)^2, L = 255, statistics of every
// window that lies inside the image ('valid' filtering), the map's mean. Per window:
//
//   SSIM = (2 mu_x mu_y + C1)(2 sigma_xy + C2) / ((mu_x^2 + mu_y^2 + C1)(sigma_x^2 + sigma_y^2 +
//   C2))
//
// Cost: the five local moments by a separable filter, O(W H 11 * 2 * 5) multiply-adds and
// O(W H) doubles of memory.
#include "hmdnode/core/image_quality.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace hmdnode {
namespace {

Status check_pair(const ImageRGBA8& ref, const ImageRGBA8& test, const char* what) {
    if (ref.empty() || test.empty()) return make_error(std::string(what) + ": empty image");
    if (ref.width != test.width || ref.height != test.height)
        return make_error(std::string(what) + ": image sizes differ (" + std::to_string(ref.width) +
                          "x" + std::to_string(ref.height) + " against " +
                          std::to_string(test.width) + "x" + std::to_string(test.height) + ")");
    return {};
}

std::vector<double> luma(const ImageRGBA8& im) {
    std::vector<double> y(size_t(im.width) * size_t(im.height));
    for (size_t i = 0; i < y.size(); ++i) {
        const uint8_t* p = &im.pixels[i * 4];
        y[i] = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
    }
    return y;
}

}  // namespace

Result<double> psnr_db(const ImageRGBA8& ref, const ImageRGBA8& test) {
    if (Status st = check_pair(ref, test, "PSNR"); !st.ok()) return st.error();
    double sum = 0.0;
    const size_t n = size_t(ref.width) * size_t(ref.height);
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const double d = double(ref.pixels[i * 4 + c]) - double(test.pixels[i * 4 + c]);
            sum += d * d;
        }
    const double mse = sum / double(n * 3);
    if (mse <= 0.0) return kPsnrCapDb;
    return std::min(kPsnrCapDb, 10.0 * std::log10(255.0 * 255.0 / mse));
}

Result<double> ssim(const ImageRGBA8& ref, const ImageRGBA8& test) {
    if (Status st = check_pair(ref, test, "SSIM"); !st.ok()) return st.error();
    constexpr int kWin = 11;
    constexpr double kSigma = 1.5;
    if (ref.width < kWin || ref.height < kWin)
        return make_error("SSIM: image " + std::to_string(ref.width) + "x" +
                          std::to_string(ref.height) + " is smaller than the 11x11 window");
    double w[kWin];
    double wsum = 0.0;
    for (int i = 0; i < kWin; ++i) {
        const double d = i - kWin / 2;
        w[i] = std::exp(-d * d / (2.0 * kSigma * kSigma));
        wsum += w[i];
    }
    for (double& v : w) v /= wsum;  // the 2-D window w[i] w[j] sums to 1

    const int W = ref.width, H = ref.height;
    const std::vector<double> x = luma(ref), y = luma(test);
    // Horizontal pass of the five signals x, y, x^2, y^2, xy into columns 0..W-kWin.
    const int ow = W - kWin + 1, oh = H - kWin + 1;
    std::vector<double> h[5];
    for (auto& v : h) v.assign(size_t(ow) * size_t(H), 0.0);
    for (int r = 0; r < H; ++r) {
        const double* xr = &x[size_t(r) * W];
        const double* yr = &y[size_t(r) * W];
        for (int c = 0; c < ow; ++c) {
            double s[5] = {0, 0, 0, 0, 0};
            for (int k = 0; k < kWin; ++k) {
                const double a = xr[c + k], b = yr[c + k], wk = w[k];
                s[0] += wk * a;
                s[1] += wk * b;
                s[2] += wk * a * a;
                s[3] += wk * b * b;
                s[4] += wk * a * b;
            }
            for (int m = 0; m < 5; ++m) h[m][size_t(r) * ow + c] = s[m];
        }
    }
    const double C1 = (0.01 * 255.0) * (0.01 * 255.0), C2 = (0.03 * 255.0) * (0.03 * 255.0);
    double total = 0.0;
    for (int r = 0; r < oh; ++r)
        for (int c = 0; c < ow; ++c) {
            double s[5] = {0, 0, 0, 0, 0};
            for (int k = 0; k < kWin; ++k)
                for (int m = 0; m < 5; ++m) s[m] += w[k] * h[m][size_t(r + k) * ow + c];
            const double mx = s[0], my = s[1];
            const double vx = s[2] - mx * mx, vy = s[3] - my * my, cxy = s[4] - mx * my;
            total += ((2.0 * mx * my + C1) * (2.0 * cxy + C2)) /
                     ((mx * mx + my * my + C1) * (vx + vy + C2));
        }
    return total / (double(ow) * double(oh));
}

}  // namespace hmdnode
