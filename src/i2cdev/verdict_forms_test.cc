// Whether what the core allowed or substituted has a form on the adapter,
// through the C ABI both clients call before a call is committed (the
// monitor's suites test it through Monitor::transfer, scenario 65 through
// both clients on i2c-stub).
#include <cstring>
#include <gtest/gtest.h>
#include <initializer_list>
#include <linux/i2c.h>

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

namespace {

// i2c-stub's functionality: SMBus only, no block or process calls.
constexpr uint64_t kStub = I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE | I2C_FUNC_SMBUS_BYTE_DATA |
                           I2C_FUNC_SMBUS_WORD_DATA | I2C_FUNC_SMBUS_I2C_BLOCK;
// An SMBus adapter that writes words and count-prefixed blocks only (no
// byte data or I2C block writes): a register written byte by byte has no
// form there, a word or a counted block has.
constexpr uint64_t kWordsAndBlocks =
    I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE | I2C_FUNC_SMBUS_READ_BYTE_DATA |
    I2C_FUNC_SMBUS_WORD_DATA | I2C_FUNC_SMBUS_WRITE_BLOCK_DATA | I2C_FUNC_SMBUS_READ_I2C_BLOCK;

// A verdict at `addr` emitting `emits`, one message each.
contego_verdict verdict(uint16_t addr, std::initializer_list<std::initializer_list<uint8_t>> emits,
                        uint8_t decision = CONTEGO_ALLOW) {
  contego_verdict v;
  std::memset(&v, 0, sizeof v);
  v.decision = decision;
  v.addr = addr;
  for (const auto& e : emits) {
    v.emit_len[v.emit_count++] = static_cast<uint16_t>(e.size());
    for (uint8_t b : e) v.emit_bytes[v.emit_bytes_used++] = b;
  }
  return v;
}

// The call's transactions, as both clients make them.
uint32_t transactions(contego_i2c_msg* m, uint32_t n, contego_i2c_tx* tx) {
  return contego_i2c_transactions(m, n, tx);
}

TEST(I2cVerdictForms, ASubstituteLongerThanAnSmbusBlockHasNoFormOnAnSmbusAdapter) {
  uint8_t w[2] = {0x06, 0x22};
  contego_i2c_msg m[1] = {{0x41, 0, 2, w}};
  contego_i2c_tx tx[1];
  ASSERT_EQ(transactions(m, 1, tx), 1u);
  contego_verdict v = verdict(0x41, {}, CONTEGO_FAILSAFE);
  v.emit_len[0] = 40;
  v.emit_count = 1;
  v.emit_bytes_used = 40;
  contego_i2c_formless why;
  std::memset(&why, 0xA5, sizeof why);
  ASSERT_EQ(contego_i2c_call_has_forms(m, 1, tx, &v, 1, kStub, &why), 0);
  EXPECT_EQ(why.tx, 0u);
  ASSERT_EQ(why.n, 1u);
  EXPECT_EQ(why.msgs[0].addr, 0x41);
  EXPECT_EQ(why.msgs[0].len, 40);
  EXPECT_EQ(why.msgs[0].buf, v.emit_bytes);
  EXPECT_EQ(why.plan.form, CONTEGO_I2C_FORM_REFUSED);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_WRITE_TOO_LONG);
  // Plain I2C carries it.
  EXPECT_EQ(contego_i2c_call_has_forms(m, 1, tx, &v, 1, I2C_FUNC_I2C, &why), 1);
}

TEST(I2cVerdictForms, AWriteActingAsSentGoesWholeItsRegistersApartDoNot) {
  // A word write checked register by register: as sent, it goes out as the
  // program's word write; with a register substituted, byte by byte, which
  // this adapter cannot.
  uint8_t w[3] = {0x08, 0x34, 0x12};
  contego_i2c_msg m[1] = {{0x40, 0, 3, w}};
  contego_i2c_tx tx[1];
  ASSERT_EQ(transactions(m, 1, tx), 1u);
  contego_i2c_formless why;
  const contego_verdict allowed = verdict(0x40, {{0x08, 0x34}, {0x09, 0x12}});
  EXPECT_EQ(contego_i2c_acts_as_sent(tx, &allowed, 1), 1);
  EXPECT_EQ(contego_i2c_call_has_forms(m, 1, tx, &allowed, 1, kWordsAndBlocks, &why), 1);
  const contego_verdict sub = verdict(0x40, {{0x08, 0x64}, {0x09, 0x12}}, CONTEGO_FAILSAFE);
  EXPECT_EQ(contego_i2c_acts_as_sent(tx, &sub, 1), 0);
  ASSERT_EQ(contego_i2c_call_has_forms(m, 1, tx, &sub, 1, kWordsAndBlocks, &why), 0);
  EXPECT_EQ(why.tx, 0u);
  EXPECT_EQ(why.msgs[0].len, 2);
  EXPECT_EQ(why.msgs[0].buf[0], 0x08);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_NO_FORM);
  ASSERT_EQ(why.plan.candidate_count, 2);
  EXPECT_EQ(why.plan.candidates[0], CONTEGO_SMBUS_BYTE_DATA);
  EXPECT_EQ(why.plan.candidates[1], CONTEGO_SMBUS_I2C_BLOCK_DATA);
  // i2c-stub writes byte data: the substitute has its form there.
  EXPECT_EQ(contego_i2c_call_has_forms(m, 1, tx, &sub, 1, kStub, &why), 1);
}

TEST(I2cVerdictForms, ALaterWriteWithoutAFormNamesItsTransaction) {
  // Two writes: a count-prefixed frame at 0x08 (an SMBus block write) and
  // a word at 0x40 the core checked register by register. The call has no
  // form whole, so each goes in its own: the first would act before the
  // second failed at the bus, hence asked first.
  uint8_t frame[4] = {0x47, 0x02, 0x00, 0x00}, word[3] = {0x00, 0x11, 0x22};
  contego_i2c_msg m[2] = {{0x08, 0, 4, frame}, {0x40, 0, 3, word}};
  contego_i2c_tx tx[2];
  ASSERT_EQ(transactions(m, 2, tx), 2u);
  const contego_verdict v[2] = {verdict(0x08, {{0x47, 0x02, 0x00, 0x00}}),
                                verdict(0x40, {{0x00, 0x11}, {0x01, 0x22}})};
  EXPECT_EQ(contego_i2c_acts_as_sent(tx, v, 2), 1);
  contego_i2c_formless why;
  ASSERT_EQ(contego_i2c_call_has_forms(m, 2, tx, v, 2, kWordsAndBlocks, &why), 0);
  EXPECT_EQ(why.tx, 1u);
  EXPECT_EQ(why.msgs[0].addr, 0x40);
  EXPECT_EQ(why.msgs[0].len, 2);
  // Each alone: the frame has its form, the word as sent too.
  contego_i2c_tx one[1];
  ASSERT_EQ(transactions(m, 1, one), 1u);
  EXPECT_EQ(contego_i2c_call_has_forms(m, 1, one, v, 1, kWordsAndBlocks, &why), 1);
  ASSERT_EQ(transactions(m + 1, 1, one), 1u);
  EXPECT_EQ(contego_i2c_call_has_forms(m + 1, 1, one, v + 1, 1, kWordsAndBlocks, &why), 1);
  // On plain I2C the call goes whole.
  EXPECT_EQ(contego_i2c_call_has_forms(m, 2, tx, v, 2, I2C_FUNC_I2C, &why), 1);
}

TEST(I2cVerdictForms, AWriteAndTheReadAnsweringItTogetherOrApart) {
  uint8_t w[3] = {0x10, 0x34, 0x12}, r[2] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD, 2, r}};
  contego_i2c_tx tx[2];
  ASSERT_EQ(transactions(m, 2, tx), 2u);
  ASSERT_EQ(contego_i2c_write_then_read(&tx[0], &tx[1]), 1);
  const uint64_t proc = kStub | I2C_FUNC_SMBUS_PROC_CALL;
  contego_i2c_formless why;
  contego_i2c_msg emit;
  // A substitute of one message goes with the read: a process call.
  contego_verdict v[2] = {verdict(0x40, {{0x10, 0x00, 0x00}}, CONTEGO_FAILSAFE), verdict(0x40, {})};
  ASSERT_EQ(contego_i2c_emit_with_read(&v[0], &m[1], proc, &emit), 1);
  EXPECT_EQ(emit.len, 3);
  EXPECT_EQ(emit.buf, v[0].emit_bytes);
  EXPECT_EQ(contego_i2c_call_has_forms(m, 2, tx, v, 2, proc, &why), 1);
  // Without the process call the pair has no form; the read of 2 alone has
  // none either (it needs a register byte before it).
  EXPECT_EQ(contego_i2c_emit_with_read(&v[0], &m[1], kStub, &emit), 0);
  ASSERT_EQ(contego_i2c_call_has_forms(m, 2, tx, v, 2, kStub, &why), 0);
  EXPECT_EQ(why.tx, 1u);
  ASSERT_EQ(why.n, 1u);
  EXPECT_EQ(why.msgs[0].flags, I2C_M_RD);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_LONG_READ_ALONE);
  // Two emits never go with the read; each and the read are asked apart.
  v[0] = verdict(0x40, {{0x10, 0x00}, {0x11, 0x00}}, CONTEGO_FAILSAFE);
  EXPECT_EQ(contego_i2c_emit_with_read(&v[0], &m[1], proc, &emit), 0);
  ASSERT_EQ(contego_i2c_call_has_forms(m, 2, tx, v, 2, proc, &why), 0);
  EXPECT_EQ(why.tx, 1u);
  // Nor does an emit at another address (a general call's substitute).
  v[0] = verdict(0x41, {{0x10, 0x00, 0x00}}, CONTEGO_FAILSAFE);
  EXPECT_EQ(contego_i2c_emit_with_read(&v[0], &m[1], proc, &emit), 0);
}

TEST(I2cVerdictForms, BeforeTheCoreDecidesTheProgramsBytes) {
  // Without verdicts: each transaction as the program sent it, a write and
  // the read answering it together when they have a form so.
  uint8_t w[3] = {0x10, 0x34, 0x12}, r[2] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD, 2, r}};
  contego_i2c_tx tx[2];
  ASSERT_EQ(transactions(m, 2, tx), 2u);
  contego_i2c_formless why;
  EXPECT_EQ(
      contego_i2c_call_has_forms(m, 2, tx, nullptr, 2, kStub | I2C_FUNC_SMBUS_PROC_CALL, &why), 1);
  // Apart: the word write has its form, the read of 2 alone none.
  ASSERT_EQ(contego_i2c_call_has_forms(m, 2, tx, nullptr, 2, kStub, &why), 0);
  EXPECT_EQ(why.tx, 1u);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_LONG_READ_ALONE);
  // A register read: the pointer and the read together, as one transaction.
  uint8_t reg[1] = {0x06}, got[40] = {};
  contego_i2c_msg rd[2] = {{0x40, 0, 1, reg}, {0x40, I2C_M_RD, 4, got}};
  ASSERT_EQ(transactions(rd, 2, tx), 1u);
  EXPECT_EQ(contego_i2c_call_has_forms(rd, 2, tx, nullptr, 1, kStub, &why), 1);
  rd[1].len = 40;  // longer than an I2C block read
  ASSERT_EQ(contego_i2c_call_has_forms(rd, 2, tx, nullptr, 1, kStub, &why), 0);
  EXPECT_EQ(why.n, 2u);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_READ_LENGTH);
  // A quick read: its zero-length message, refused without the quick bit.
  contego_i2c_msg q[1] = {{0x40, I2C_M_RD, 0, nullptr}};
  tx[0] = {};
  tx[0].kind = CONTEGO_TX_QUICK;
  tx[0].addr = 0x40;
  tx[0].msg_count = 1;
  EXPECT_EQ(contego_i2c_call_has_forms(q, 1, tx, nullptr, 1, kStub, &why), 1);
  EXPECT_EQ(contego_i2c_call_has_forms(q, 1, tx, nullptr, 1, kStub & ~I2C_FUNC_SMBUS_QUICK, &why),
            0);
}

TEST(I2cVerdictForms, EmitsOneByOne) {
  contego_i2c_formless why;
  const contego_verdict v = verdict(0x40, {{0x06, 0x01}, {0x00, 0x20, 0x21, 0x22}, {0x07}});
  EXPECT_EQ(contego_i2c_emits_have_forms(&v, 0, kStub, &why), 1);
  ASSERT_EQ(contego_i2c_emits_have_forms(&v, 0, kWordsAndBlocks, &why), 0);
  EXPECT_EQ(why.msgs[0].len, 2);  // the first
  // A ten-bit address has no SMBus form.
  ASSERT_EQ(contego_i2c_emits_have_forms(&v, I2C_M_TEN, kStub, &why), 0);
  EXPECT_EQ(why.plan.refusal, CONTEGO_I2C_TEN_BIT);
  EXPECT_EQ(why.msgs[0].flags, I2C_M_TEN);
  // Nothing to send, nothing to refuse.
  const contego_verdict none = verdict(0x40, {});
  EXPECT_EQ(contego_i2c_emits_have_forms(&none, 0, 0, &why), 1);
  // Emits that overrun the verdict's bytes are the sender's to fail (EIO,
  // before any byte).
  contego_verdict bad = verdict(0x40, {{0x06, 0x01}});
  bad.emit_len[0] = CONTEGO_MAX_EMIT_BYTES + 1;
  EXPECT_EQ(contego_i2c_emits_have_forms(&bad, 0, kStub, &why), 1);
}

TEST(I2cVerdictForms, AQuickCommandNeverActsAsSentReadsAreThePrograms) {
  contego_i2c_msg q[1] = {{0x40, 0, 0, nullptr}};
  contego_i2c_tx tx[1] = {};
  tx[0].kind = CONTEGO_TX_QUICK;
  tx[0].addr = 0x40;
  tx[0].msg_count = 1;
  const contego_verdict v = verdict(0x40, {});
  EXPECT_EQ(contego_i2c_acts_as_sent(tx, &v, 1), 0);
  contego_i2c_formless why;
  EXPECT_EQ(contego_i2c_call_has_forms(q, 1, tx, &v, 1, kStub, &why), 1);
  // A register read sends nothing of the core's.
  uint8_t reg[1] = {0x06}, r[4] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 1, reg}, {0x40, I2C_M_RD, 4, r}};
  ASSERT_EQ(transactions(m, 2, tx), 1u);
  EXPECT_EQ(contego_i2c_acts_as_sent(tx, &v, 1), 1);
  EXPECT_EQ(contego_i2c_call_has_forms(m, 2, tx, &v, 1, kStub, &why), 1);
}

}  // namespace
