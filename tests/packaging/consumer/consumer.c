/* Uses the installed core through its C facade: a checker in caller memory. */
#include <contego/core_c.h>
#include <stdio.h>
#include <stdlib.h>

int main(void) {
  void* mem = aligned_alloc(contego_checker_align(),
                            (contego_checker_size() + contego_checker_align() - 1) /
                                contego_checker_align() * contego_checker_align());
  contego_checker* c = contego_checker_init(mem, contego_checker_size());
  printf("checker of %zu bytes: %s\n", contego_checker_size(), c ? "ok" : "failed");
  free(mem);
  return c ? 0 : 1;
}
