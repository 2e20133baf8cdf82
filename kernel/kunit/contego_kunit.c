// SPDX-License-Identifier: GPL-2.0
/*
 * contego.ko's pure parts as the kernel runs them (docs/kernel-client.md,
 * "KUnit"): the i2c-dev model it shares with the monitor (planning, the
 * SMBus call table, the retry rule of I2C_RETRIES/I2C_TIMEOUT, the job grid
 * and the hold's counts, the message flag allow-list), compiled from the
 * same sources with the same kernel flags as in contego.ko, and its session
 * rules (counting by unit, the hand-off to a group's leader). The monitor's
 * GoogleTest suites test the same sources in user space; these show the
 * kernel's build of them agrees.
 *
 * Debian's kernels are built without KUnit: the test bed loads kunit.ko
 * built from Debian's linux-source (kernel/build.sh --kunit), which has no
 * module notifier there, so this module hands its suites to KUnit itself.
 */
#include <kunit/test.h>
#include <linux/i2c.h>
#include <linux/module.h>

#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"
#include "contego/job_budget.h"
#include "contego/session_room.h"

/* i2c-stub's functionality: SMBus only, no block or process calls. */
#define CT_STUB_FUNCS (I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE | I2C_FUNC_SMBUS_BYTE_DATA | \
		       I2C_FUNC_SMBUS_WORD_DATA | I2C_FUNC_SMBUS_I2C_BLOCK)

static void ct_plan(struct contego_i2c_msg *m, u32 n, u64 funcs, struct contego_i2c_plan *p)
{
	memset(p, 0xA5, sizeof(*p)); /* every field is set by the planner */
	contego_i2c_plan_transfer(m, n, funcs, p);
}

static void ct_kunit_layout(struct kunit *test)
{
	/* contego.ko hands its struct i2c_msg array to the model as it is. */
	KUNIT_EXPECT_EQ(test, sizeof(struct contego_i2c_msg), sizeof(struct i2c_msg));
	KUNIT_EXPECT_EQ(test, offsetof(struct contego_i2c_msg, buf), offsetof(struct i2c_msg, buf));
	KUNIT_EXPECT_EQ(test, CONTEGO_SMBUS_DATA_BYTES, sizeof(union i2c_smbus_data));
	KUNIT_EXPECT_EQ(test, CONTEGO_I2C_M_NOSTART, I2C_M_NOSTART);
	KUNIT_EXPECT_EQ(test, CONTEGO_I2C_M_RECV_LEN, I2C_M_RECV_LEN);
}

static void ct_kunit_plain_adapter(struct kunit *test)
{
	u8 w[3] = { 0x06, 0x01, 0x02 }, r[2] = { 0 };
	struct contego_i2c_msg m[2] = { { 0x40, 0, 3, w }, { 0x40, I2C_M_RD, 2, r } };
	struct contego_i2c_plan p;

	ct_plan(m, 2, I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL, &p);
	KUNIT_EXPECT_EQ(test, p.form, CONTEGO_I2C_FORM_I2C);
	KUNIT_EXPECT_EQ(test, p.refusal, CONTEGO_I2C_NOT_REFUSED);
}

static void ct_kunit_smbus_forms(struct kunit *test)
{
	u8 w[2] = { 0x06, 0x99 }, r[4] = { 0 };
	struct contego_i2c_msg write[1] = { { 0x40, 0, 2, w } };
	struct contego_i2c_msg read[2] = { { 0x40, 0, 1, w }, { 0x40, I2C_M_RD, 4, r } };
	u8 data[CONTEGO_SMBUS_DATA_BYTES] = { 4, 0xA, 0xB, 0xC, 0xD };
	struct contego_i2c_plan p;

	ct_plan(write, 1, CT_STUB_FUNCS, &p);
	KUNIT_ASSERT_EQ(test, p.form, CONTEGO_I2C_FORM_SMBUS);
	KUNIT_EXPECT_EQ(test, p.op.size, CONTEGO_SMBUS_BYTE_DATA);
	KUNIT_EXPECT_EQ(test, p.op.command, 0x06);
	KUNIT_EXPECT_EQ(test, p.op.data[0], 0x99);
	KUNIT_EXPECT_EQ(test, p.op.reply, -1);

	/* A combined read of four on an SMBus-only adapter: an I2C block read. */
	ct_plan(read, 2, CT_STUB_FUNCS, &p);
	KUNIT_ASSERT_EQ(test, p.form, CONTEGO_I2C_FORM_SMBUS);
	KUNIT_EXPECT_EQ(test, p.op.size, CONTEGO_SMBUS_I2C_BLOCK_DATA);
	KUNIT_EXPECT_EQ(test, p.op.read, 1);
	KUNIT_EXPECT_EQ(test, p.op.reply, 1);
	KUNIT_EXPECT_EQ(test, contego_i2c_deliver_reply(&p.op, data, read, 2), 0);
	KUNIT_EXPECT_EQ(test, r[0], 0xA);
	KUNIT_EXPECT_EQ(test, r[3], 0xD);
}

static void ct_kunit_refusals(struct kunit *test)
{
	u8 w[40] = { 0x06 }, r[33] = { 1 };
	struct contego_i2c_msg too_long[1] = { { 0x40, 0, 40, w } };
	struct contego_i2c_msg block[2] = { { 0x40, 0, 1, w },
					    { 0x40, I2C_M_RD | I2C_M_RECV_LEN, 33, r } };
	struct contego_i2c_msg mangled[1] = { { 0x40, I2C_M_RD | I2C_M_REV_DIR_ADDR, 1, r } };
	struct contego_i2c_plan p;

	ct_plan(too_long, 1, CT_STUB_FUNCS, &p);
	KUNIT_EXPECT_EQ(test, p.form, CONTEGO_I2C_FORM_REFUSED);
	KUNIT_EXPECT_EQ(test, p.refusal, CONTEGO_I2C_WRITE_TOO_LONG);
	ct_plan(block, 2, CT_STUB_FUNCS, &p);
	KUNIT_EXPECT_EQ(test, p.refusal, CONTEGO_I2C_NO_FORM);
	KUNIT_ASSERT_EQ(test, p.candidate_count, 1);
	KUNIT_EXPECT_STREQ(test, contego_smbus_name(p.candidates[0], p.candidates_read),
			   "SMBus block read");
	ct_plan(mangled, 1, CT_STUB_FUNCS, &p);
	KUNIT_EXPECT_EQ(test, p.refusal, CONTEGO_I2C_FLAGS);
	KUNIT_EXPECT_EQ(test, p.flags, I2C_M_RD | I2C_M_REV_DIR_ADDR);
}

static void ct_kunit_flag_allow_list(struct kunit *test)
{
	static const unsigned int mangling[] = { I2C_M_NOSTART, I2C_M_REV_DIR_ADDR,
						 I2C_M_IGNORE_NAK, I2C_M_STOP, I2C_M_NO_RD_ACK };
	unsigned int i;

	KUNIT_EXPECT_EQ(test, contego_i2c_refused_flags(I2C_M_RD | I2C_M_RECV_LEN), 0u);
	KUNIT_EXPECT_EQ(test, contego_i2c_refused_flags(I2C_M_TEN), 0u);
	KUNIT_EXPECT_EQ(test, contego_i2c_refused_flags(I2C_M_RECV_LEN), (unsigned int)I2C_M_RECV_LEN);
	for (i = 0; i < ARRAY_SIZE(mangling); i++) {
		KUNIT_EXPECT_EQ(test, contego_i2c_refused_flags(I2C_M_RD | mangling[i]), mangling[i]);
		KUNIT_EXPECT_EQ(test, contego_i2c_refused_flags(mangling[i]), mangling[i]);
	}
	KUNIT_EXPECT_STREQ(test, contego_i2c_flag_name(I2C_M_REV_DIR_ADDR), "I2C_M_REV_DIR_ADDR");
}

static void ct_kunit_smbus_call_table(struct kunit *test)
{
	u8 data[CONTEGO_SMBUS_DATA_BYTES] = { 0x34, 0x12 };
	u8 wire[CONTEGO_SMBUS_WIRE_BYTES], rbuf[CONTEGO_SMBUS_DATA_BYTES - 1];
	struct contego_i2c_msg m[2];

	/* A word write: one message, the command byte and the word, low first. */
	KUNIT_ASSERT_EQ(test, contego_i2c_smbus_msgs(0x40, 0, 0, 0x10, CONTEGO_SMBUS_WORD_DATA,
						     data, m, wire, rbuf), 1);
	KUNIT_EXPECT_EQ(test, m[0].len, 3);
	KUNIT_EXPECT_EQ(test, m[0].buf[0], 0x10);
	KUNIT_EXPECT_EQ(test, m[0].buf[1], 0x34);
	/* An SMBus block read: the pointer, then a counted read of 33. */
	KUNIT_ASSERT_EQ(test, contego_i2c_smbus_msgs(0x40, 0, 1, 0x10, CONTEGO_SMBUS_BLOCK_DATA,
						     data, m, wire, rbuf), 2);
	KUNIT_EXPECT_EQ(test, m[1].flags, I2C_M_RD | I2C_M_RECV_LEN);
	KUNIT_EXPECT_EQ(test, m[1].len, 33);
	/* An unknown size is refused. */
	KUNIT_EXPECT_LT(test, contego_i2c_smbus_msgs(0x40, 0, 0, 0x10, 6, data, m, wire, rbuf), 0);
	/* With PEC on the wire, a byte write ends with its PEC: CRC-8 of
	 * 0x80 (0x40 writing), 0x10, 0x34 is 0xd0; a read's request has none.
	 */
	KUNIT_ASSERT_EQ(test, contego_i2c_smbus_msgs(0x40, I2C_CLIENT_PEC, 0, 0x10,
						     CONTEGO_SMBUS_BYTE_DATA, data, m, wire, rbuf), 1);
	KUNIT_EXPECT_EQ(test, m[0].len, 3);
	KUNIT_EXPECT_EQ(test, m[0].buf[2], 0xd0);
	KUNIT_ASSERT_EQ(test, contego_i2c_smbus_msgs(0x40, I2C_CLIENT_PEC, 1, 0x10,
						     CONTEGO_SMBUS_BYTE_DATA, data, m, wire, rbuf), 2);
	KUNIT_EXPECT_EQ(test, m[0].len, 1);
}

static void ct_kunit_timing(struct kunit *test)
{
	/* The retry rule the monitor applies reads the kernel's own EAGAIN,
	 * and stops where __i2c_transfer's loop does: after retries + 1
	 * tries, or once time_after(jiffies, first + timeout).
	 */
	KUNIT_EXPECT_EQ(test, CONTEGO_EAGAIN, EAGAIN);
	KUNIT_EXPECT_EQ(test, contego_i2c_try_again(EAGAIN, 3, 3, HZ, HZ), 1);
	KUNIT_EXPECT_EQ(test, contego_i2c_try_again(EAGAIN, 4, 3, 0, HZ), 0);
	KUNIT_EXPECT_EQ(test, contego_i2c_try_again(EAGAIN, 1, 3, HZ + 1, HZ), 0);
	KUNIT_EXPECT_EQ(test, contego_i2c_try_again(ENXIO, 1, 3, 0, HZ), 0);
	/* i2c-dev's limits, as contego.ko's I2C_RETRIES and I2C_TIMEOUT take them. */
	KUNIT_EXPECT_EQ(test, contego_i2c_timing_arg_ok(0, INT_MAX), 1);
	KUNIT_EXPECT_EQ(test, contego_i2c_timing_arg_ok(1, INT_MAX / 10 + 1), 0);
}

/* A verdict at 0x40 with the emits `bytes` cut at `lens` (kept off the stack). */
static contego_verdict *ct_verdict(struct kunit *test, const u8 *bytes, const u16 *lens, u32 n)
{
	contego_verdict *v = kunit_kzalloc(test, sizeof(*v), GFP_KERNEL);
	u32 i;

	KUNIT_ASSERT_NOT_NULL(test, v);
	v->addr = 0x40;
	for (i = 0; i < n; i++) {
		memcpy(v->emit_bytes + v->emit_bytes_used, bytes + v->emit_bytes_used, lens[i]);
		v->emit_len[v->emit_count++] = lens[i];
		v->emit_bytes_used += lens[i];
	}
	return v;
}

static void ct_kunit_verdict_forms(struct kunit *test)
{
	/* Word writes but no byte data or I2C block writes. */
	const u64 words = CT_STUB_FUNCS & ~(u64)(I2C_FUNC_SMBUS_WRITE_BYTE_DATA |
						 I2C_FUNC_SMBUS_WRITE_I2C_BLOCK);
	static const u8 sent[] = { 0x10, 0x34, 0x11, 0x12 }, sub[] = { 0x10, 0x64, 0x11, 0x12 };
	static const u8 zeros[40];
	static const u16 pairs[] = { 2, 2 }, forty[] = { 40 };
	u8 w[3] = { 0x10, 0x34, 0x12 };
	struct contego_i2c_msg m[1] = { { 0x40, 0, 3, w } };
	struct contego_i2c_formless why;
	struct contego_i2c_tx tx[1];
	contego_verdict *v;

	KUNIT_ASSERT_EQ(test, contego_i2c_transactions(m, 1, tx), 1u);
	/* The program's bytes, before the core decides: a word write. */
	KUNIT_EXPECT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, NULL, 1, words, &why), 1);
	/* Checked register by register and allowed: the program's word write. */
	v = ct_verdict(test, sent, pairs, 2);
	KUNIT_EXPECT_EQ(test, contego_i2c_acts_as_sent(tx, v, 1), 1);
	KUNIT_EXPECT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, v, 1, words, &why), 1);
	/* A register substituted: byte by byte, which this adapter cannot. */
	v = ct_verdict(test, sub, pairs, 2);
	KUNIT_ASSERT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, v, 1, words, &why), 0);
	KUNIT_EXPECT_EQ(test, why.tx, 0u);
	KUNIT_EXPECT_EQ(test, why.msgs[0].len, 2);
	KUNIT_EXPECT_EQ(test, why.plan.refusal, CONTEGO_I2C_NO_FORM);
	KUNIT_EXPECT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, v, 1, CT_STUB_FUNCS, &why), 1);
	/* 40 bytes: no SMBus write carries them, plain I2C does. */
	v = ct_verdict(test, zeros, forty, 1);
	KUNIT_ASSERT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, v, 1, CT_STUB_FUNCS, &why), 0);
	KUNIT_EXPECT_EQ(test, why.plan.refusal, CONTEGO_I2C_WRITE_TOO_LONG);
	KUNIT_EXPECT_EQ(test, contego_i2c_call_has_forms(m, 1, tx, v, 1, I2C_FUNC_I2C, &why), 1);
}

static void ct_kunit_job_grid(struct kunit *test)
{
	KUNIT_EXPECT_EQ(test, contego_grid_job(1000, 10000, 500), 1u);
	KUNIT_EXPECT_EQ(test, contego_grid_job(1000, 10000, 10999), 1u);
	KUNIT_EXPECT_EQ(test, contego_grid_job(1000, 10000, 11000), 2u);
	KUNIT_EXPECT_EQ(test, contego_grid_job(1000, 0, 11000), 0u);
	/* A time far past the phase: the job number still fits. */
	KUNIT_EXPECT_EQ(test, contego_grid_job(0, 10000, 10000ull * 3000000000ull), 3000000001u);
	KUNIT_EXPECT_EQ(test, contego_grid_first_release(1, 1000, 10000, 12345), 11000ull);
	KUNIT_EXPECT_EQ(test, contego_grid_first_release(0, 0, 10000, 12345), 12345ull);
}

static void ct_kunit_charging(struct kunit *test)
{
	struct contego_job_budget b = { 0 };
	int i;

	/* Acting transfers: F x N a job, then the next is charged to the next job. */
	for (i = 0; i < 3; i++) {
		KUNIT_ASSERT_EQ(test, contego_budget_before(&b, 1, 10000, 3), 1u);
		KUNIT_EXPECT_EQ(test, contego_budget_after(&b, 1, 10000, 1, 8), 0);
	}
	KUNIT_EXPECT_EQ(test, contego_budget_before(&b, 1, 10000, 3), 2u);
	/* Transfers that did not act have their own count: the ninth waits. */
	b = (struct contego_job_budget){ 0 };
	for (i = 0; i < 8; i++)
		KUNIT_EXPECT_EQ(test, contego_budget_after(&b, 1, 10000, 0, 8), 0);
	KUNIT_EXPECT_EQ(test, contego_budget_after(&b, 1, 10000, 0, 8), 1);
	KUNIT_EXPECT_EQ(test, contego_budget_before(&b, 1, 10000, 3), 1u);
}

static void ct_kunit_session_room(struct kunit *test)
{
	/* Units are opaque keys: the module's are struct pid pointers. */
	static const int units[4];
	uintptr_t mine = (uintptr_t)&units[0], a = (uintptr_t)&units[1];
	uintptr_t b = (uintptr_t)&units[2], c = (uintptr_t)&units[3];
	struct contego_session_room *r = kunit_kzalloc(test, sizeof(*r), GFP_KERNEL);

	KUNIT_ASSERT_NOT_NULL(test, r);
	/* sessions = 2: two other units live, none the caller's: no room. */
	contego_room_start(r, mine, 2);
	KUNIT_EXPECT_TRUE(test, contego_room_count(r, a));
	KUNIT_EXPECT_TRUE(test, contego_room_count(r, a)); /* a unit's sessions count once */
	KUNIT_EXPECT_TRUE(test, contego_room_left(r));
	KUNIT_EXPECT_TRUE(test, contego_room_count(r, b));
	KUNIT_EXPECT_FALSE(test, contego_room_left(r));
	/* The caller's own unit has a session: it joins it, whatever the count. */
	KUNIT_EXPECT_FALSE(test, contego_room_count(r, mine));
	KUNIT_EXPECT_TRUE(test, contego_room_left(r));
	/* sessions = 1 (the default): one other unit fills it. */
	contego_room_start(r, mine, 1);
	KUNIT_EXPECT_TRUE(test, contego_room_left(r));
	contego_room_count(r, c);
	KUNIT_EXPECT_FALSE(test, contego_room_left(r));
	/* More than the cap asked for is the cap. */
	contego_room_start(r, mine, 1000);
	KUNIT_EXPECT_EQ(test, r->allowed, (u32)CONTEGO_ROOM_UNITS);
}

static void ct_kunit_session_unit(struct kunit *test)
{
	const uintptr_t me = 0x1000, group = 0x2000;

	/* A script's i2cset: the script's group is its unit, and its clean
	 * exit hands the session to the script.
	 */
	KUNIT_EXPECT_EQ(test, contego_session_unit(me, group, 1), group);
	KUNIT_EXPECT_TRUE(test, contego_session_hands_to_leader(0, me, group, 1));
	/* Killed (wait status 9), failing (exit 1), the leader itself, the
	 * leader gone, or no group: its own unit, and it ends at once.
	 */
	KUNIT_EXPECT_FALSE(test, contego_session_hands_to_leader(9, me, group, 1));
	KUNIT_EXPECT_FALSE(test, contego_session_hands_to_leader(1 << 8, me, group, 1));
	KUNIT_EXPECT_EQ(test, contego_session_unit(me, me, 1), me);
	KUNIT_EXPECT_FALSE(test, contego_session_hands_to_leader(0, me, me, 1));
	KUNIT_EXPECT_EQ(test, contego_session_unit(me, group, 0), me);
	KUNIT_EXPECT_FALSE(test, contego_session_hands_to_leader(0, me, group, 0));
	KUNIT_EXPECT_EQ(test, contego_session_unit(me, 0, 1), me);
}

static struct kunit_case ct_model_cases[] = {
	KUNIT_CASE(ct_kunit_layout),
	KUNIT_CASE(ct_kunit_plain_adapter),
	KUNIT_CASE(ct_kunit_smbus_forms),
	KUNIT_CASE(ct_kunit_refusals),
	KUNIT_CASE(ct_kunit_flag_allow_list),
	KUNIT_CASE(ct_kunit_smbus_call_table),
	KUNIT_CASE(ct_kunit_timing),
	KUNIT_CASE(ct_kunit_verdict_forms),
	{}
};

static struct kunit_case ct_budget_cases[] = {
	KUNIT_CASE(ct_kunit_job_grid),
	KUNIT_CASE(ct_kunit_charging),
	KUNIT_CASE(ct_kunit_session_room),
	KUNIT_CASE(ct_kunit_session_unit),
	{}
};

static struct kunit_suite ct_model_suite = {
	.name = "contego_i2c_model",
	.test_cases = ct_model_cases,
};

static struct kunit_suite ct_budget_suite = {
	.name = "contego_budget_and_sessions",
	.test_cases = ct_budget_cases,
};

static struct kunit_suite *ct_suites[] = { &ct_model_suite, &ct_budget_suite };

static int __init ct_kunit_init(void)
{
	return __kunit_test_suites_init(ct_suites, ARRAY_SIZE(ct_suites));
}
module_init(ct_kunit_init);

static void __exit ct_kunit_exit(void)
{
	__kunit_test_suites_exit(ct_suites, ARRAY_SIZE(ct_suites));
}
module_exit(ct_kunit_exit);

MODULE_DESCRIPTION("KUnit tests of contego.ko's shared i2c-dev model and session rules");
MODULE_LICENSE("GPL");
