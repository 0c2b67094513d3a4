// Full-reference image quality of one 8-bit RGBA image against another of the same size: PSNR and
// SSIM (core/src/image_quality.cpp). Alpha is ignored.
#pragma once

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/result.hpp"

namespace hmdnode {

// PSNR of identical images (MSE 0) is infinite; it is reported as this cap so that a report stays
// finite JSON. 100 dB is an MSE of 6.5e-6: fewer than one channel value off by one 8-bit step in
// 150,000, so a near-identical large image reads 100 dB too (docs/formats.md).
inline constexpr double kPsnrCapDb = 100.0;

// PSNR of `test` against `ref` in dB over the R, G and B channels: 10 log10(255^2 / MSE), capped
// at kPsnrCapDb. Error when the sizes differ or the images are empty.
Result<double> psnr_db(const ImageRGBA8& ref, const ImageRGBA8& test);

// Mean SSIM of the 8-bit luma (BT.601: Y = 0.299 R + 0.587 G + 0.114 B) of `test` against `ref`:
// Wang, Bovik, Sheikh, Simoncelli 2004, 11x11 Gaussian window (sigma 1.5), K1 0.01, K2 0.03,
// L 255, averaged over every window that lies inside the image (no padding). 1 for identical
// images. Error when the sizes differ or an image is smaller than the window.
Result<double> ssim(const ImageRGBA8& ref, const ImageRGBA8& test);

}  // namespace hmdnode
