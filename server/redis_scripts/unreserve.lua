-- After limits.lua. Drops a claim.
-- KEYS: limits.lua's. ARGV: token at 6.
unclaim(ARGV[6])
return 0
