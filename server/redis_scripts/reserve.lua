-- After limits.lua. Claims a session slot and ARGV[4] bytes for an upload.
-- KEYS, ARGV: limits.lua's (KEYS[1] unused; ARGV[7] the claim's ttl).
-- Returns {code, count} as create.lua's.
local refused = over(ARGV)
if refused then return refused end
local expiry = now_ms() + tonumber(ARGV[7])
redis.call('ZADD', KEYS[4], expiry, KEYS[5] .. '|' .. ARGV[6])
redis.call('ZADD', KEYS[5], expiry, ARGV[6])
redis.call('HSET', KEYS[6], ARGV[6], ARGV[4])
return {0, 0}
