/* The control interface of contego.ko (docs/kernel-client.md): the ioctls on
 * /dev/contego with which `contego kmod load` hands the module a compiled
 * policy image and the task bindings. Shared by the module (C, kernel) and
 * the CLI (C++, user space). */
#ifndef CONTEGO_KMOD_H_
#define CONTEGO_KMOD_H_

#include <linux/ioctl.h>
#include <linux/types.h>

#define CONTEGO_KMOD_MAX_IMAGE (4u << 20) /* bytes */
#define CONTEGO_KMOD_MAX_BINDS 64

/* A process whose effective uid is `uid` acts as task `task` (its id in the
 * image). A process no binding names is no task: the policy's default
 * (deny) applies to it. */
struct contego_kmod_bind {
  __u32 uid;
  __u16 task;
  __u16 pad;
};

struct contego_kmod_load {
  __u64 image;   /* in: user pointer to the image */
  __u32 size;    /* in: its size in bytes */
  __u32 nbinds;  /* in: entries at `binds` */
  __u64 binds;   /* in: user pointer to struct contego_kmod_bind[nbinds] */
  __u32 status;  /* out: the core verifier's LoadStatus (0 = loaded) */
  __u32 section; /* out: where the verifier stopped */
  __u32 index;   /* out */
  __u32 devices; /* out: devices driven to their safe state at load */
};

struct contego_kmod_stats {
  __u64 loads;         /* images accepted */
  __u64 refused_loads; /* images the verifier refused (the previous one stayed) */
  __u64 checks;        /* transactions checked */
  __u64 performed;     /* calls that acted on a bus */
  __u64 refused;       /* calls refused (errno to the program) */
  __u64 ignored;       /* calls ignored (success, nothing acted) */
  __u64 failsafe;      /* calls replaced by a substitute or the safe state */
  __u32 loaded;        /* 1: an image is in force */
  __u32 pad;
};

#define CONTEGO_KMOD_IOC_MAGIC 0xC7
#define CONTEGO_KMOD_LOAD _IOWR(CONTEGO_KMOD_IOC_MAGIC, 1, struct contego_kmod_load)
#define CONTEGO_KMOD_STATS _IOR(CONTEGO_KMOD_IOC_MAGIC, 2, struct contego_kmod_stats)

#endif /* CONTEGO_KMOD_H_ */
