-- After limits.lua. Stores a new record, consuming the claim ARGV[6].
-- KEYS, ARGV: limits.lua's; ARGV[7] the record's ttl, ARGV[8..] its
-- field/value pairs (with the incarnation as 'inc').
-- Returns {code, count}: 0 created (or created before by this same call),
-- 1 exists, else as limits.lua's over().
if redis.call('EXISTS', KEYS[1]) == 1 then
  -- This very creation, retried after its reply was lost: done.
  for i = 8, #ARGV - 1, 2 do
    if ARGV[i] == 'inc' and redis.call('HGET', KEYS[1], 'inc') == ARGV[i + 1] then
      return {0, 0}
    end
  end
  return {1, 0}
end
local refused = over(ARGV)
if refused then return refused end
unclaim(ARGV[6])
local fields = {}
for i = 8, #ARGV do fields[#fields + 1] = ARGV[i] end
redis.call('HSET', KEYS[1], unpack(fields))
redis.call('PEXPIRE', KEYS[1], ARGV[7])
local id = string.sub(KEYS[1], #ARGV[5] + 1)
redis.call('ZADD', KEYS[2], 0, id)
redis.call('ZADD', KEYS[3], 0, KEYS[1])
return {0, 0}
