// Experiment, not used by mcd (benchmarks/thin_group_conv_kernel.py; docs/inference.md, "A direct kernel for
// thin groups"): a direct 7x7 group convolution, bf16 in, fp32 out, AVX-512 BF16 dot products (vdpbf16ps)
// over pairs of input channels, 16 output pixels per register, R output rows x CO outputs of a group held in
// registers while the input rows stream past.
// x2: [B, G, CP, Hp, Wp, 2] bf16 (input channel pairs interleaved, zero-padded: Hp >= H + K - 1 + 8,
// Wp >= Wr + K - 1); w2: [G, CO, CP, K, K, 2] bf16; out: [B, G, CO, H, Wr] fp32, Wr a multiple of 16.
#include <torch/extension.h>
#include <ATen/Parallel.h>
#include <immintrin.h>
#include <cstdint>

namespace {

template <int R, int CO, int K>
void block(const uint16_t* x, const uint16_t* w, float* out, int64_t CP, int64_t Hp, int64_t Wp, int64_t H,
           int64_t Wr, int64_t y0) {
  const int rows = static_cast<int>(std::min<int64_t>(R, H - y0));
  for (int64_t x0 = 0; x0 < Wr; x0 += 16) {
    __m512 acc[R][CO];
    for (int i = 0; i < R; ++i)
      for (int o = 0; o < CO; ++o) acc[i][o] = _mm512_setzero_ps();
    for (int64_t cp = 0; cp < CP; ++cp) {
      const uint16_t* xc = x + cp * Hp * Wp * 2;
      const uint16_t* wc = w + cp * K * K * 2;
#pragma GCC unroll 32
      for (int r = 0; r < R + K - 1; ++r) {
        const uint16_t* xr = xc + ((y0 + r) * Wp + x0) * 2;
#pragma GCC unroll 8
        for (int dx = 0; dx < K; ++dx) {
          const __m512bh v = (__m512bh)_mm512_loadu_si512(xr + dx * 2);
#pragma GCC unroll 16
          for (int i = 0; i < R; ++i) {
            const int dy = r - i;
            if (dy < 0 || dy >= K) continue;
#pragma GCC unroll 16
            for (int o = 0; o < CO; ++o) {
              const int32_t wv = *reinterpret_cast<const int32_t*>(wc + ((o * CP * K + dy) * K + dx) * 2);
              acc[i][o] = _mm512_dpbf16_ps(acc[i][o], v, (__m512bh)_mm512_set1_epi32(wv));
            }
          }
        }
      }
    }
    for (int i = 0; i < rows; ++i)
      for (int o = 0; o < CO; ++o) _mm512_storeu_ps(out + (o * H + y0 + i) * Wr + x0, acc[i][o]);
  }
}

template <int R, int CO, int K>
void run(const torch::Tensor& x2, const torch::Tensor& w2, torch::Tensor& out) {
  const int64_t B = x2.size(0), G = x2.size(1), CP = x2.size(2), Hp = x2.size(3), Wp = x2.size(4);
  const int64_t H = out.size(3), Wr = out.size(4);
  const int64_t blocks = (H + R - 1) / R;
  const auto* xp = reinterpret_cast<const uint16_t*>(x2.data_ptr<at::BFloat16>());
  const auto* wp = reinterpret_cast<const uint16_t*>(w2.data_ptr<at::BFloat16>());
  float* op = out.data_ptr<float>();
  at::parallel_for(0, B * G * blocks, 1, [&](int64_t begin, int64_t end) {
    for (int64_t t = begin; t < end; ++t) {
      const int64_t b = t / (G * blocks), j = (t / blocks) % G, yb = t % blocks;
      block<R, CO, K>(xp + (b * G + j) * CP * Hp * Wp * 2, wp + j * CO * CP * K * K * 2,
                      op + (b * G + j) * CO * H * Wr, CP, Hp, Wp, H, Wr, yb * R);
    }
  });
}

}  // namespace

torch::Tensor thin_group_conv(const torch::Tensor& x2, const torch::Tensor& w2, int64_t H, int64_t Wr) {
  TORCH_CHECK(x2.is_contiguous() && w2.is_contiguous() && x2.scalar_type() == at::kBFloat16 &&
              w2.scalar_type() == at::kBFloat16, "thin_group_conv: contiguous bf16 inputs expected");
  const int64_t CO = w2.size(1), K = w2.size(3);
  TORCH_CHECK(K == 7 && Wr % 16 == 0 && x2.size(4) >= Wr + K - 1 && x2.size(3) >= H + K - 1 + 8,
              "thin_group_conv: 7x7 kernels and padded inputs expected");
  auto out = torch::empty({x2.size(0), x2.size(1), CO, H, Wr}, x2.options().dtype(at::kFloat));
  switch (CO) {
    case 2: run<8, 2, 7>(x2, w2, out); break;
    case 5: run<4, 5, 7>(x2, w2, out); break;
    case 6: run<4, 6, 7>(x2, w2, out); break;
    case 10: run<2, 10, 7>(x2, w2, out); break;
    case 12: run<2, 12, 7>(x2, w2, out); break;
    default: TORCH_CHECK(false, "thin_group_conv: ", CO, " outputs per group is not compiled");
  }
  return out;
}

PYBIND11_MODULE(TORCH_EXTENSION_NAME, m) { m.def("thin_group_conv", &thin_group_conv); }
