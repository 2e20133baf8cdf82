/* The i2c-dev model both enclave clients share (docs/kernel-client.md, "One
 * i2c-dev model"): how a combined transfer becomes the trusted core's
 * transactions, and how it reaches an adapter: as plain I2C (I2C_RDWR) when
 * the adapter has I2C_FUNC_I2C, otherwise as the one SMBus transaction that
 * puts exactly the same bytes on the wire, chosen by the adapter's
 * I2C_FUNCS bits; or a refusal with its reason, decided before any part of
 * the transfer acts. contego.ko links it beside the core, the monitor and
 * `contego run` through src/bus and src/gate: one planner, so a transfer
 * that one client can send the other can too.
 *
 * Wire forms (S start, Sr repeated start, P stop, A address):
 *   [write 0]                      quick write        S A+W P
 *   [read 0]                       quick read         S A+R P
 *   [write c]                      send byte          S A+W c P
 *   [read 1]                       receive byte       S A+R d P
 *   [write c d]                    write byte data    (or I2C block write of 1)
 *   [write c lo hi]                write word data    (or I2C block write of 2,
 *                                                      or SMBus block write if hi == 1)
 *   [write c d1..dn], n <= 32      I2C block write    (or SMBus block write if d1 == n-1)
 *   [write c 32 d1..d32]           SMBus block write  (only form of 34 bytes)
 *   [write c][read 1]              read byte data     (or I2C block read of 1)
 *   [write c][read 2]              read word data     (or I2C block read of 2)
 *   [write c][read n], 3 <= n <= 32  I2C block read
 *   [write c][read RECV_LEN]       SMBus block read
 *   [write c lo hi][read 2]        process call
 *   [write c k d1..dk][read RECV_LEN], 1 <= k <= 32  block process call
 * The raw I2C-block form is preferred over the count-prefixed SMBus block
 * form: both put the same bytes on the wire, but only the former is chosen
 * for bytes that merely happen to look count-prefixed. Every other shape
 * has no SMBus form and is refused on an adapter without plain I2C.
 *
 * Freestanding C ABI (implemented in C++, src/i2cdev): no allocation, no
 * OS calls, no floating point; usable in the kernel. */
#ifndef CONTEGO_I2C_PLAN_H_
#define CONTEGO_I2C_PLAN_H_

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* One message of a combined transfer: struct i2c_msg's layout, so the kernel
 * passes its own array. For a read, `buf` receives up to `len` bytes. */
struct contego_i2c_msg {
  uint16_t addr;
  uint16_t flags; /* CONTEGO_I2C_M_* (contego/i2c_msg_flags.h) */
  uint16_t len;
  uint8_t *buf;
};

/* I2C_SMBUS transaction sizes (<linux/i2c.h>). */
enum contego_smbus_size {
  CONTEGO_SMBUS_QUICK = 0,
  CONTEGO_SMBUS_BYTE = 1,
  CONTEGO_SMBUS_BYTE_DATA = 2,
  CONTEGO_SMBUS_WORD_DATA = 3,
  CONTEGO_SMBUS_PROC_CALL = 4,
  CONTEGO_SMBUS_BLOCK_DATA = 5,
  CONTEGO_SMBUS_BLOCK_PROC_CALL = 7,
  CONTEGO_SMBUS_I2C_BLOCK_DATA = 8,
};

#define CONTEGO_SMBUS_BLOCK_MAX 32u
#define CONTEGO_SMBUS_DATA_BYTES 34u /* union i2c_smbus_data */
#define CONTEGO_SMBUS_WIRE_BYTES 35u /* an SMBus write: command, count, 32 data bytes, spare */

/* One I2C_SMBUS call. `data` is union i2c_smbus_data as bytes, with the word
 * as [lo, hi] (the order on the wire; the executor converts to the host's
 * u16): byte in data[0]; word in data[0..1]; block: data[0] = count (I2C
 * block read: bytes wanted), then the bytes. */
struct contego_smbus_op {
  uint16_t addr;
  uint8_t read; /* read_write is I2C_SMBUS_READ (quick: the R/W bit) */
  uint8_t command;
  uint8_t size; /* enum contego_smbus_size */
  uint8_t data[CONTEGO_SMBUS_DATA_BYTES];
  int32_t reply; /* the read message that receives the result, -1: none */
};

enum contego_i2c_form {
  CONTEGO_I2C_FORM_I2C = 0,
  CONTEGO_I2C_FORM_SMBUS = 1,
  CONTEGO_I2C_FORM_REFUSED = 2
};

/* Why a transfer has no form on the adapter (contego_i2c_refusal_text). */
enum contego_i2c_refusal {
  CONTEGO_I2C_NOT_REFUSED = 0,
  CONTEGO_I2C_NO_MESSAGES,
  CONTEGO_I2C_NO_ZERO_LENGTH, /* plain I2C without the quick bit */
  CONTEGO_I2C_TEN_BIT,
  CONTEGO_I2C_FLAGS, /* plan.flags: the message's flags */
  CONTEGO_I2C_RECV_LEN_SHAPE,
  CONTEGO_I2C_NO_BYTES,
  CONTEGO_I2C_NO_FORM, /* plan.candidates: the forms the adapter lacks */
  CONTEGO_I2C_WRITE_TOO_LONG,
  CONTEGO_I2C_COUNTED_READ_ALONE,
  CONTEGO_I2C_LONG_READ_ALONE,
  CONTEGO_I2C_EMPTY_POINTER,
  CONTEGO_I2C_READ_LENGTH,
  CONTEGO_I2C_WRITE_READ_SHAPE,
  CONTEGO_I2C_SHAPE,
};

struct contego_i2c_plan {
  uint8_t form;               /* enum contego_i2c_form */
  uint8_t refusal;            /* enum contego_i2c_refusal */
  uint8_t candidates_read;    /* NO_FORM: read forms (for their names) */
  uint8_t candidate_count;    /* NO_FORM */
  uint8_t candidates[3];      /* NO_FORM: sizes, preferred first */
  uint16_t flags;             /* FLAGS */
  struct contego_smbus_op op; /* FORM_SMBUS */
};

/* The form of one combined transfer on an adapter with I2C_FUNCS `funcs`. */
void contego_i2c_plan_transfer(const struct contego_i2c_msg *msgs, uint32_t n, uint64_t funcs,
                               struct contego_i2c_plan *plan);

/* Copies the result of a read op (`data` as I2C_SMBUS returned it, word as
 * [lo, hi]) into the read message op->reply names, setting its len
 * (RECV_LEN: 1 + count). 0, or a positive Linux errno: EPROTO (71) for a
 * block count of 0, above 32 or beyond the message's buffer, EINVAL (22) for
 * a reply index outside msgs. Nothing to do for a write. */
int contego_i2c_deliver_reply(const struct contego_smbus_op *op,
                              const uint8_t data[CONTEGO_SMBUS_DATA_BYTES],
                              struct contego_i2c_msg *msgs, uint32_t n);

/* Human names, for messages and audit. */
const char *contego_smbus_name(uint32_t size, int read);
/* The fixed part of a refusal's reason ("a ten-bit address needs an adapter
 * with plain I2C", ...); NO_FORM and FLAGS add their details. */
const char *contego_i2c_refusal_text(uint32_t refusal);

/* One transaction for the trusted core (contego_transaction's fields) and
 * the messages it covers. */
struct contego_i2c_tx {
  uint8_t kind; /* CONTEGO_TX_WRITE, _READ or _QUICK (contego/core_c.h) */
  uint8_t ten;
  uint16_t addr;
  uint32_t len;
  const uint8_t *bytes; /* a write's bytes, or a read's register pointer */
  uint32_t first_msg;   /* messages [first_msg, first_msg + msg_count) */
  uint32_t msg_count;
};

/* The normalisation every client shares (docs/gate-protocol.md,
 * "Normalisation"): every write message is a write transaction of its bytes,
 * except that a one-byte write followed by a read of the same address (not
 * the general call address 0) is that read's register pointer; every other
 * read is a read without pointer. `out` has room for n; returns how many. */
uint32_t contego_i2c_transactions(const struct contego_i2c_msg *msgs, uint32_t n,
                                  struct contego_i2c_tx *out);

/* Whether transactions a and b, adjacent in one call, are a write and the
 * read that answers it without a register pointer of its own (a process
 * call, a read at a two-byte register address): the program sent them as
 * one combined transfer, with a repeated start and no stop between, and a
 * client sends them so again when the write goes out as one message. Not
 * at the general call address, which is write-only. */
int contego_i2c_write_then_read(const struct contego_i2c_tx *a, const struct contego_i2c_tx *b);

/* Whether a write's verdict puts exactly the write's bytes on the wire, at
 * `addr`: one emit of them, or emits that are the write cut where the
 * core's commands end, each [register, data...] at the register after the
 * previous one's data (a register map's auto-increment write checked
 * register by register). Then the write goes out as the program's one
 * message, not as one message per command. `v` is a contego_verdict
 * (contego/core_c.h). */
struct contego_verdict;
int contego_i2c_emits_as_sent(const struct contego_verdict *v, uint16_t addr, const uint8_t *bytes,
                              uint32_t len);

/* Whether every write of a decided call goes out exactly as sent
 * (contego_i2c_emits_as_sent), and it has no quick command: then a client
 * may send the call as the program's one combined transfer. */
int contego_i2c_acts_as_sent(const struct contego_i2c_tx *txs, const struct contego_verdict *v,
                             uint32_t n);

/* What a decided call would send that has no form on the adapter: the part
 * (one emit, or an emit with the read answering it) as messages -- a write's
 * `buf` points into the verdict, a read's is the caller's -- the planner's
 * refusal of it, and the transaction it belongs to. */
struct contego_i2c_formless {
  uint32_t tx;
  uint32_t n; /* messages: 1 or 2 */
  struct contego_i2c_msg msgs[2];
  struct contego_i2c_plan plan; /* form CONTEGO_I2C_FORM_REFUSED and why */
};

/* Whether a write's verdict `v` with one emit and `read`, the read of the
 * same call that answers the write (contego_i2c_write_then_read), go out as
 * one transfer with a repeated start, as the program sent them: the emit is
 * at the read's address and the two have a form together on an adapter
 * with I2C_FUNCS `funcs`. Then *emit is the emit as a message. */
int contego_i2c_emit_with_read(const struct contego_verdict *v, const struct contego_i2c_msg *read,
                               uint64_t funcs, struct contego_i2c_msg *emit);

/* Whether each emit of `v`, a message of its own at v's address (`ten`:
 * CONTEGO_I2C_M_TEN or 0), has a form. 0: *why names the first that has
 * none (why->tx left 0). A verdict whose emits overrun its bytes is left
 * to the sender, which fails it closed before its first byte. */
int contego_i2c_emits_have_forms(const struct contego_verdict *v, uint16_t ten, uint64_t funcs,
                                 struct contego_i2c_formless *why);

/* Whether every part of a call has a form on an adapter with I2C_FUNCS
 * `funcs`, as both clients send it: `msgs` (nmsgs), `txs` (its n
 * transactions, contego_i2c_transactions's) and, once the core has decided,
 * `v` (their verdicts). Both clients ask before the core decides (`v` NULL:
 * the program's bytes) and again, when the call acts, before the core's
 * transfer is committed: what the verdicts send (a substitute, the core's
 * register-by-register writes) may have no form where the program's bytes
 * had one. Either way a part without one refuses the call whole
 * (EOPNOTSUPP), so that no part of it acts before a later part fails at
 * the bus. The parts: the program's call whole when it acts as sent
 * (contego_i2c_acts_as_sent) and has a form whole; otherwise transaction by
 * transaction: reads and quick commands as sent; a write as sent, or each
 * emit of its verdict as a message of its own, except that a write of one
 * message (one emit) and the read answering it go together when they have
 * a form together (contego_i2c_emit_with_read). 1: every part has a form;
 * 0: *why names the first that has none. */
int contego_i2c_call_has_forms(const struct contego_i2c_msg *msgs, uint32_t nmsgs,
                               const struct contego_i2c_tx *txs, const struct contego_verdict *v,
                               uint32_t n, uint64_t funcs, struct contego_i2c_formless *why);

/* The messages an I2C_SMBUS call puts on the wire, i2c-core's SMBus
 * emulation's table (the rows of the planner's, backwards): `data` is the
 * call's union i2c_smbus_data as bytes (word as [lo, hi]), copied in, with
 * I2C_SMBUS_I2C_BLOCK_BROKEN already made I2C_SMBUS_I2C_BLOCK_DATA. A write's
 * bytes go to `wire`; a read message receives into `rbuf` (RECV_LEN's
 * count preset to 1). `read`: the call's read_write is I2C_SMBUS_READ.
 * `flags`: CONTEGO_I2C_M_TEN for a ten-bit address; CONTEGO_I2C_CLIENT_PEC
 * when the descriptor asked for packet error checking (I2C_PEC) and the
 * adapter puts it on the wire (contego_i2c_pec_on_wire). Then, for the calls
 * that carry it (contego_i2c_smbus_pec_kept), a call that only writes ends
 * with its PEC, one more byte (i2c-core's i2c_smbus_add_pec): a byte of the
 * write like any other, which the core checks (a register map's
 * auto-increment stores it in the next register) and which is sent as such,
 * never added again; a call that reads gets one more byte from the device,
 * its PEC, which the client compares (contego_smbus_pec) before it answers,
 * EBADMSG on a mismatch, as i2c-core does (contego_i2c_answer_pec).
 * Returns the number of messages (1 or 2), or -22 (EINVAL) for an unknown
 * size or a block count above 32. */
#define CONTEGO_I2C_CLIENT_PEC 0x0004u     /* the kernel's I2C_CLIENT_PEC */
#define CONTEGO_I2C_FUNC_SMBUS_PEC 0x0008u /* <linux/i2c.h>'s I2C_FUNC_SMBUS_PEC */
int contego_i2c_smbus_msgs(uint16_t addr, uint16_t flags, uint8_t read, uint8_t command,
                           uint32_t size, const uint8_t data[CONTEGO_SMBUS_DATA_BYTES],
                           struct contego_i2c_msg m[2], uint8_t wire[CONTEGO_SMBUS_WIRE_BYTES],
                           uint8_t rbuf[CONTEGO_SMBUS_DATA_BYTES - 1]);

/* Whether a descriptor's SMBus writes carry a PEC on the wire: it set
 * I2C_PEC (`pec`) and the adapter has I2C_FUNC_SMBUS_PEC (i2c-core's
 * emulation on a plain I2C adapter, or a controller that computes it); an
 * adapter without it sends none, whatever the descriptor asked. */
static inline int contego_i2c_pec_on_wire(int pec, uint64_t funcs) {
  return pec && (funcs & CONTEGO_I2C_FUNC_SMBUS_PEC) != 0;
}

/* Whether an I2C_SMBUS call of `size` (read: its read_write is
 * I2C_SMBUS_READ) carries its PEC through contego when the wire has one:
 * every call but a quick command and an I2C block transfer (i2c-core adds
 * none to them) and the counted reads, an SMBus block read and a block
 * process call, whose answer one byte longer has no form in the planner:
 * they are sent without PEC, their data unverified. */
static inline int contego_i2c_smbus_pec_kept(uint32_t size, int read) {
  return size != CONTEGO_SMBUS_QUICK && size != CONTEGO_SMBUS_I2C_BLOCK_DATA &&
         size != CONTEGO_SMBUS_BLOCK_PROC_CALL && !(size == CONTEGO_SMBUS_BLOCK_DATA && read);
}

/* SMBus's packet error code: CRC-8 (x^8 + x^2 + x + 1) of `n` bytes, on from
 * `crc` (0 to start). i2c-core computes it over each message's address byte
 * ((addr << 1) | R/W) and then its bytes. */
uint8_t contego_smbus_pec(uint8_t crc, const uint8_t *bytes, uint32_t n);

/* The PEC an SMBus call's answer must continue to, as i2c-core checks it:
 * over each of the call's `n` messages before the last, its address byte
 * and its bytes, then the last's (the read's) address byte. The answer's
 * bytes but its last, on from it, must give its last byte. */
uint8_t contego_i2c_answer_pec(const struct contego_i2c_msg *m, uint32_t n);

/* I2C_RETRIES and I2C_TIMEOUT: i2c-core's rule for one transfer
 * (__i2c_transfer and __i2c_smbus_xfer), which both clients apply with a
 * descriptor's own values, never adapter-wide as i2c-dev does (issue 37).
 * After try number `tries` (1: the first) ended with `err` (a positive
 * errno, 0 for success: the kernel's result negated), `elapsed` after the
 * first try began, the transfer is tried again only if the driver lost
 * arbitration (EAGAIN), tries <= retries, and elapsed has not passed
 * `timeout` (in elapsed's unit: i2c-core compares jiffies with time_after,
 * so a try ending exactly at the timeout may be followed by one more).
 * contego.ko has i2c-core apply it, lending the descriptor's values to the
 * adapter under its bus lock; the monitor, which must not change its
 * adapter's, tries a call's acting transfers again by this function. Pure:
 * the caller reads its clock. */
#define CONTEGO_EAGAIN 11u                   /* Linux's: arbitration lost */
#define CONTEGO_I2C_TIMEOUT_UNIT_MS 10u      /* I2C_TIMEOUT's argument: tens of ms */
#define CONTEGO_I2C_ADAPTER_TIMEOUT_MS 1000u /* i2c-core's for an adapter that sets none */
int contego_i2c_try_again(uint32_t err, uint32_t tries, uint32_t retries, uint64_t elapsed,
                          uint64_t timeout);

/* Whether i2c-dev takes `arg` for I2C_RETRIES (`timeout` 0: up to INT_MAX)
 * or for I2C_TIMEOUT (1: up to INT_MAX / 10, so that arg * 10 ms does not
 * wrap); the ioctl answers EINVAL otherwise. */
int contego_i2c_timing_arg_ok(int timeout, uint64_t arg);

#ifdef __cplusplus
}
#endif

#endif /* CONTEGO_I2C_PLAN_H_ */
