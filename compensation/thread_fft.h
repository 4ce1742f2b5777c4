// Eigen's FFT keeps its plan (the twiddle factors) in the object: one per thread, reused by
// every analysis in the folder. Private to compensation's sources (it brings in Eigen).
#pragma once

#include <unsupported/Eigen/FFT>

namespace gaugeloop {

Eigen::FFT<double>& thread_fft();

}  // namespace gaugeloop
