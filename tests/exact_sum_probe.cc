// Reads doubles (one a line, any strtod form, hex floats included) from
// stdin and prints their ExactSum's Round() and Terms() as hex floats, one
// line each: the Python test compares them with math.fsum.
#include <cstdio>
#include <cstdlib>

#include "lib/core/exact_sum.h"

int main() {
  meshgauge::ExactSum sum;
  char line[128];
  while (std::fgets(line, sizeof line, stdin) != nullptr) {
    sum.Add(std::strtod(line, nullptr));
  }
  std::printf("%a\n", sum.Round());
  for (double t : sum.Terms()) std::printf("%a ", t);
  std::printf("\n");
  return 0;
}
