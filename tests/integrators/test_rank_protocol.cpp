// The pieces of a render under MPI that need no MPI: the bands of tiles each rank owns, a
// band's owner (its passes added in order, whoever rendered them), and the messages between
// ranks, every one of which refuses a truncated or ill-fitting copy with a clear error.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "integrators/rank_protocol.h"
#include "integrators/tile_owner.h"

namespace cierzo {
namespace {

TEST(TileBands, EveryPixelHasOneOwnerAndOneSlotInItsBand) {
    for (int ranks : {1, 2, 3, 7, 40}) {
        const TileBands b(70, 37, ranks);  // (5 × 3 tiles, edge tiles cut short)
        ASSERT_EQ(b.tiles(), 15u);
        EXPECT_EQ(b.first(0), 0u);
        EXPECT_EQ(b.first(ranks), b.tiles());
        std::set<std::pair<int, size_t>> slots;
        for (uint32_t p = 0; p < 70u * 37u; ++p) {
            const size_t k = b.tile_of(p);
            const int o = b.owner(k);
            ASSERT_GE(k, b.first(o));
            ASSERT_LT(k, b.first(o + 1));
            const size_t s = b.slot(p);
            EXPECT_LT(s, b.count(o) * TileBands::kSlots);
            EXPECT_TRUE(slots.insert({o, s}).second) << "two pixels share slot " << s;
        }
    }
}

// A band of 2 tiles at rank 1 of 2: units come in any order and are added in pass order.
TEST(TileOwner, AddsPassesInOrderWhoeverRenderedThem) {
    const TileBands bands(32, 32, 2);  // 4 tiles; rank 1 owns tiles 2 and 3
    TilePool pool;
    TileOwner owner(bands, 1, 0, false, pool, true);
    const std::vector<Tile> units = image_tiles(32, 32);
    const auto unit = [&](int tile, int pass, double value) {
        UnitResult r{Unit{tile, pass, pass, pass + 1}, pool.make(units[size_t(tile)], 32), {}, {}};
        for (PixelSums& p : r.sums.pixels()) p.sum[0] = value, p.count = 1;
        r.rays.camera = 1;
        return r;
    };
    // Pass 1 comes before pass 0: it waits aside
    owner.complete(unit(2, 1, 0.25));
    owner.complete(unit(3, 0, 1.0));
    EXPECT_FALSE(owner.take_report());
    owner.complete(unit(2, 0, 0.5));
    const std::optional<PassReport> rep = owner.take_report();
    ASSERT_TRUE(rep);
    EXPECT_EQ(rep->pass, 0);
    EXPECT_EQ(rep->rays.camera, 2u);
    EXPECT_THROW(owner.complete(unit(3, 0, 1.0)), std::runtime_error);  // (twice)
    EXPECT_THROW(owner.complete(unit(0, 1, 1.0)), std::runtime_error);  // (not its tile)
    owner.advance(1);
    owner.complete(unit(3, 1, 2.0));
    ASSERT_TRUE(owner.take_report());
    owner.advance(2);
    EXPECT_THROW(owner.complete(unit(2, 0, 1.0)), std::runtime_error);  // (a pass added)
    const BandState s = owner.snapshot();
    // Tile 2's pixels: 0.5 then 0.25 (in that order); tile 3's: 1 then 2
    EXPECT_EQ(s.film[0].sum[0], 0.5 + 0.25);
    EXPECT_EQ(s.film[0].count, 2u);
    EXPECT_EQ(s.film[TileBands::kSlots].sum[0], 1.0 + 2.0);
    EXPECT_THROW(owner.advance(4), std::runtime_error);  // (pass 2 is not reported)
}

TEST(TileOwner, RefusesSplatsOutsideItsBand) {
    const TileBands bands(32, 32, 2);
    TilePool pool;
    TileOwner owner(bands, 0, 1, true, pool, false);
    EXPECT_THROW(owner.add_splats(0, {{uint32_t(31 * 32 + 31), Vec3f{1, 1, 1}}}),
                 std::runtime_error);
    EXPECT_THROW(owner.add_splats(0, {{uint32_t(32 * 32), Vec3f{1, 1, 1}}}), std::runtime_error);
    EXPECT_NO_THROW(owner.add_splats(0, {{uint32_t(0), Vec3f{1, 1, 1}}}));
}

// Every message, cut at every length short of its own, and with bytes added, is refused with
// an error that names the sender.
template <class Decode>
void refuses_every_cut(const std::vector<char>& m, Decode decode) {
    EXPECT_NO_THROW(decode(m));
    for (size_t n = 0; n < m.size(); ++n) {
        const std::vector<char> cut(m.begin(), m.begin() + ptrdiff_t(n));
        try {
            decode(cut);
            ADD_FAILURE() << "a message cut to " << n << " of " << m.size() << " bytes was taken";
        } catch (const MessageError& e) {
            EXPECT_NE(std::string(e.what()).find("rank 5 sent a malformed"), std::string::npos)
                << e.what();
        }
    }
    std::vector<char> longer = m;
    longer.push_back(0);
    EXPECT_THROW(decode(longer), MessageError);
}

TEST(RankMessages, RoundTripAndRefuseTruncatedCopies) {
    const std::string from = "rank 5";
    const wire::Request q{7, 3};
    const wire::Request q2 = wire::decode_request(wire::encode(q), from);
    EXPECT_EQ(q2.want, 7);
    EXPECT_EQ(q2.holding, 3);
    EXPECT_TRUE(wire::is_request(wire::encode(q)));
    refuses_every_cut(wire::encode(q),
                      [&](const auto& m) { return wire::decode_request(m, from); });

    const wire::Control c{1, 4, 3, 0, 2, {Unit{5, 4, 64, 80}, Unit{6, 5, 80, 96}}};
    const wire::Control c2 = wire::decode_control(wire::encode(c), from);
    EXPECT_EQ(c2.frontier, 4);
    EXPECT_EQ(c2.checkpoint, 2);
    ASSERT_EQ(c2.units.size(), 2u);
    EXPECT_EQ(c2.units[1].s1, 96);
    refuses_every_cut(wire::encode(c),
                      [&](const auto& m) { return wire::decode_control(m, from); });
    EXPECT_FALSE(wire::is_request(wire::encode(c)));
    // (a message of one kind is not read as another)
    EXPECT_THROW(wire::decode_report(wire::encode(c), from), MessageError);

    PassReport r;
    r.pass = 3, r.error.total = (SplatSums::Fixed(1) << 90) + 5, r.error.used = 9;
    r.error.estimated = 10, r.rays.shadow = 77;
    const PassReport r2 = wire::decode_report(wire::encode(r), from);
    EXPECT_TRUE(r2.error.total == r.error.total);
    EXPECT_EQ(r2.rays.shadow, 77u);
    refuses_every_cut(wire::encode(r), [&](const auto& m) { return wire::decode_report(m, from); });

    const wire::Splats sp{2, RayCounts{1, 2, 3, 4}, {{9, Vec3f{1, 2, 3}}, {10, Vec3f{4, 5, 6}}}};
    const wire::Splats sp2 = wire::decode_splats(wire::encode(sp), from);
    ASSERT_EQ(sp2.splats.size(), 2u);
    EXPECT_EQ(sp2.splats[1].pixel, 10u);
    EXPECT_EQ(sp2.light_rays.light, 4u);
    refuses_every_cut(wire::encode(sp),
                      [&](const auto& m) { return wire::decode_splats(m, from); });

    wire::State st{wire::kFinalState, {}};
    st.band.film.resize(2 * TileBands::kSlots);
    st.band.film[3].sum[1] = 0.125;
    st.band.pending_tiles = {0, 1};
    st.band.pending.resize(2 * TileBands::kSlots);
    const auto decode_state = [&](const auto& m) {
        return wire::decode_state(m, 2 * TileBands::kSlots, from);
    };
    EXPECT_EQ(decode_state(wire::encode(st)).band.film[3].sum[1], 0.125);
    refuses_every_cut(wire::encode(st), decode_state);
    // (a band of another size than the rank owns)
    EXPECT_THROW(wire::decode_state(wire::encode(st), 3 * TileBands::kSlots, from), MessageError);
}

TEST(RankMessages, ResultsOfUnknownOrMisfitTilesAreRefused) {
    const std::string from = "rank 5";
    const std::vector<Tile> units = image_tiles(40, 20);  // 3 × 2 tiles, the last column 8 wide
    TilePool pool;
    UnitResult r{Unit{2, 0, 0, 1}, pool.make(units[2], 40), {}, {}};
    r.sums.pixels()[0].sum[2] = 3.5;
    std::vector<UnitResult> rs;
    rs.push_back(std::move(r));
    const std::vector<char> m = wire::encode(rs);
    const std::vector<UnitResult> back = wire::decode_results(m, units, pool, from);
    ASSERT_EQ(back.size(), 1u);
    EXPECT_EQ(back[0].sums.pixels()[0].sum[2], 3.5);
    EXPECT_EQ(back[0].sums.pixels().size(), 8u * 16u);
    refuses_every_cut(m, [&](const auto& x) { return wire::decode_results(x, units, pool, from); });
    // The same bytes claimed for a tile of another size, or one that does not exist
    for (int tile : {0, 6, -1}) {
        std::vector<char> other = m;
        const int32_t t = tile;
        std::memcpy(other.data() + 4, &t, sizeof(t));  // (after the kind: the unit's tile)
        EXPECT_THROW(wire::decode_results(other, units, pool, from), MessageError) << tile;
    }
}

}  // namespace
}  // namespace cierzo
