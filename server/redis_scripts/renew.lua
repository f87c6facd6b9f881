-- After limits.lua. Extends a live claim.
-- KEYS: limits.lua's. ARGV: token at 6, ttl ms at 7.
local expiry = now_ms() + tonumber(ARGV[7])
redis.call('ZADD', KEYS[4], 'XX', expiry, KEYS[5] .. '|' .. ARGV[6])
redis.call('ZADD', KEYS[5], 'XX', expiry, ARGV[6])
return 0
